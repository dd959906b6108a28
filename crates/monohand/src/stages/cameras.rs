//! The camera of each view, frame by frame: the calibrations the user gave (scaled to the
//! frames' size when it differs and has the same shape), or without them a camera per image
//! from the focal length its file states (a photo's EXIF, a video's QuickTime metadata),
//! else the generic 60 degree guess; each kind said once.

use crate::base::camera::{CameraError, CameraOrigin, StatedCamera};
use crate::base::notes::{Note, NoteTopic};
use monohand_core::camera::{Camera, Extrinsics};
use monohand_io::jsonl::CameraSource;
use monohand_media::video::VideoCameraTags;
use monohand_vision::image_io::{focal_from_35mm, ExifFocal};

/// `reason` and `more` joined, either possibly absent.
fn join_reasons(reason: Option<String>, more: Option<&String>) -> Option<String> {
    match (reason, more) {
        (Some(a), Some(b)) => Some(format!("{a}; {b}")),
        (a, b) => a.or_else(|| b.cloned()),
    }
}

/// The cameras in use and where each came from; the fitter's camera choice.
#[derive(Debug, Clone)]
pub(crate) struct CameraChoice {
    /// The calibrations the user gave, as given (empty: a camera per image).
    calibrated: Vec<Camera>,
    /// The reason each calibration is used despite a field of view outside 5-150 degrees.
    calibrated_fov: Vec<Option<String>>,
    /// The cameras in use: the calibrations, scaled to the frames' size when it differs,
    /// or the last image's camera.
    cameras: Vec<Camera>,
    /// Where each of `cameras` came from.
    origins: Vec<CameraOrigin>,
    /// The kinds of camera already announced (each is said once).
    said: Vec<String>,
    /// What to tell the user, until taken.
    notes: Vec<Note>,
}

/// What is worth saying about the calibrations given, one note each: a field of view
/// outside 5-150 degrees (used as given: it is the user's own), and extrinsics on the first
/// camera (the joints are then in the frame it maps from, not in its own).
pub(crate) fn calibration_notes(cameras: &[Camera]) -> Vec<Note> {
    let mut notes = Vec::new();
    if cameras.first().is_some_and(|c| !c.extrinsics.is_identity()) {
        notes.push(Note::new(
            NoteTopic::Calibration,
            "the first camera has extrinsics: the joints are in the frame they map from, not \
             in this camera's frame",
        ));
    }
    for (v, c) in cameras.iter().enumerate() {
        if let Some(why) = field_of_view_reason(c) {
            notes.push(Note::new(
                NoteTopic::Calibration,
                format!("camera {}: {why}", v + 1),
            ));
        }
    }
    notes
}

/// Why a calibration is used although its field of view is outside 5-150 degrees.
fn field_of_view_reason(camera: &Camera) -> Option<String> {
    camera.implausible_field_of_view().map(|why| {
        format!("the calibration gives {why}; used as given, since it is the user's own")
    })
}

impl CameraChoice {
    /// The choice for these calibrations (checked by the caller), with their notes
    /// ([`calibration_notes`]).
    pub(crate) fn new(cameras: Vec<Camera>) -> CameraChoice {
        let calibrated_fov: Vec<Option<String>> =
            cameras.iter().map(field_of_view_reason).collect();
        let notes = calibration_notes(&cameras);
        CameraChoice {
            origins: calibrated_fov
                .iter()
                .map(|why| CameraOrigin::new(CameraSource::File, why.clone()))
                .collect(),
            calibrated_fov,
            calibrated: cameras.clone(),
            cameras,
            said: Vec::new(),
            notes,
        }
    }

    /// The cameras in use.
    pub(crate) fn cameras(&self) -> &[Camera] {
        &self.cameras
    }

    /// Where each camera in use came from.
    pub(crate) fn origins(&self) -> &[CameraOrigin] {
        &self.origins
    }

    /// The notes since the last call, to be said in their turn.
    pub(crate) fn take_notes(&mut self) -> Vec<Note> {
        std::mem::take(&mut self.notes)
    }

    /// Says `message` once per `kind` of camera.
    fn say_once(&mut self, kind: String, message: String) {
        if !self.said.contains(&kind) {
            self.said.push(kind);
            self.notes.push(Note::new(NoteTopic::Camera, message));
        }
    }

    /// Makes the cameras fit the frame (`sizes`: each view's image size, `None` for an
    /// unreadable view): without calibrated cameras, one for the first view's size from the
    /// focal length its file states (`stated`), else the generic guess; with them, the
    /// calibrations, scaled to the frames' size when it differs and has the same shape
    /// (another shape is the error).
    pub(crate) fn camera_for(
        &mut self,
        sizes: &[Option<(u32, u32)>],
        stated: &StatedCamera,
    ) -> Result<(), CameraError> {
        if self.calibrated.is_empty() {
            let Some(&Some((w, h))) = sizes.first() else {
                return Ok(());
            };
            return match stated {
                StatedCamera::None => self.photo_camera(w, h, &ExifFocal::None),
                StatedCamera::Exif(focal) => self.photo_camera(w, h, focal),
                StatedCamera::QuickTime(tags) => self.video_camera(w, h, tags),
            };
        }
        for (v, size) in sizes.iter().enumerate() {
            let (Some(&(w, h)), Some(cal)) = (size.as_ref(), self.calibrated.get(v)) else {
                continue;
            };
            let k = cal.intrinsics;
            let fov = self.calibrated_fov.get(v).cloned().flatten();
            let (cam, origin) = if (k.width, k.height) == (w, h) {
                (*cal, CameraOrigin::new(CameraSource::File, fov))
            } else {
                let scaled = cal
                    .scaled_to(w, h)
                    .map_err(|source| CameraError::Calibration {
                        view: v + 1,
                        source,
                    })?;
                let why = format!(
                    "calibrated for {}x{}, scaled by {:.4} to the frames' {w}x{h}",
                    k.width,
                    k.height,
                    w as f64 / k.width as f64
                );
                self.say_once(
                    format!("file-scaled {v} {w}x{h}"),
                    format!(
                        "camera {}: {why} (fx {:.1} -> {:.1} px); a calibration at the \
                         frames' own size is better (docs/calibration.md)",
                        v + 1,
                        k.fx,
                        scaled.intrinsics.fx
                    ),
                );
                let reason = join_reasons(Some(why), fov.as_ref());
                (scaled, CameraOrigin::new(CameraSource::FileScaled, reason))
            };
            if let (Some(c), Some(o)) = (self.cameras.get_mut(v), self.origins.get_mut(v)) {
                *c = cam;
                *o = origin;
            }
        }
        Ok(())
    }

    /// The camera of a photo without calibration: from the focal length its EXIF states
    /// when that passed its checks, else the generic guess (with why, when the EXIF stated
    /// one).
    fn photo_camera(&mut self, w: u32, h: u32, focal: &ExifFocal) -> Result<(), CameraError> {
        let f = match focal {
            ExifFocal::Used(f) => f,
            ExifFocal::Refused(why) => {
                let reason = format!("the EXIF focal length was not used: {why}");
                return self.generic_camera(w, h, Some(("generic, EXIF refused", reason)));
            }
            ExifFocal::None => return self.generic_camera(w, h, None),
        };
        let cam = Camera::centred(f.px, w, h)?;
        let source = if f.sensor_width_mm.is_some() {
            CameraSource::ExifSensorDb
        } else {
            CameraSource::Exif
        };
        let why = f
            .fallback
            .as_ref()
            .map(|why| format!(" ({why})"))
            .unwrap_or_default();
        self.say_once(
            source.to_string(),
            format!(
                "the camera comes from the photo's {}: fx = fy = {:.1} px for {w}x{h} \
                 ({:.1} degree horizontal field of view; photos without it get the \
                 generic 60 degree guess){why}",
                f.source,
                f.px,
                horizontal_fov_deg(f.px, w)
            ),
        );
        self.use_camera(cam, CameraOrigin::new(source, f.fallback.clone()));
        Ok(())
    }

    /// The camera of a video's frame without calibration: from the 35 mm-equivalent focal
    /// length its QuickTime metadata states, on the frame's diagonal and checked as a
    /// photo's EXIF is, else the generic guess with why.
    fn video_camera(&mut self, w: u32, h: u32, tags: &VideoCameraTags) -> Result<(), CameraError> {
        let stated = tags.describe();
        let px = match tags.focal_35mm_mm() {
            None => return self.generic_camera(w, h, None),
            Some(Ok(f35)) => focal_from_35mm(f35, &stated, w, h).map_err(|e| e.to_string()),
            Some(Err(why)) => Err(why.to_string()),
        };
        let px = match px {
            Ok(px) => px,
            Err(why) => {
                let reason = format!("the video's focal length was not used: {why}");
                return self.generic_camera(
                    w,
                    h,
                    Some(("generic, video metadata refused", reason)),
                );
            }
        };
        let cam = Camera::centred(px, w, h)?;
        self.say_once(
            CameraSource::VideoMetadata.to_string(),
            format!(
                "the camera comes from the video's {stated}: fx = fy = {px:.1} px for {w}x{h} \
                 ({:.1} degree horizontal field of view; the 35 mm equivalent spans the \
                 frame's diagonal; videos without it get the generic 60 degree guess)",
                horizontal_fov_deg(px, w)
            ),
        );
        self.use_camera(cam, CameraOrigin::new(CameraSource::VideoMetadata, None));
        Ok(())
    }

    /// The generic guess for a `w` x `h` frame; `refused`: the kind of focal length the
    /// file stated and why it was not used (said once per kind).
    fn generic_camera(
        &mut self,
        w: u32,
        h: u32,
        refused: Option<(&str, String)>,
    ) -> Result<(), CameraError> {
        let guess =
            format!("assuming a generic camera for {w}x{h} (60 degree horizontal field of view)");
        let then = "absolute depth is only as right as this guess (docs/calibration.md)";
        let origin = match refused {
            Some((kind, reason)) => {
                self.say_once(kind.into(), format!("{reason}; {guess} instead; {then}"));
                CameraOrigin::new(CameraSource::Generic, Some(reason))
            }
            None => {
                self.say_once("generic".into(), format!("{guess}; {then}"));
                CameraOrigin::new(CameraSource::Generic, None)
            }
        };
        self.use_camera(Camera::generic(w, h)?, origin);
        Ok(())
    }

    /// Uses `cam` (the one camera: no calibrations) from `origin`.
    fn use_camera(&mut self, cam: Camera, origin: CameraOrigin) {
        self.cameras = vec![cam];
        self.origins = vec![origin];
    }
}

/// The horizontal field of view of focal length `px` across `w` pixels, degrees.
fn horizontal_fov_deg(px: f64, w: u32) -> f64 {
    2.0 * (0.5 * f64::from(w) / px).atan().to_degrees()
}

/// The cameras re-expressed in the first one's frame: the first without extrinsics, each
/// other mapping the first's frame into its own. A fit with them is in the first camera's
/// frame whatever the cameras' world frame is.
pub(crate) fn in_first_frame(cameras: &[Camera]) -> Vec<Camera> {
    let Some(first) = cameras.first() else {
        return Vec::new();
    };
    let from_first = first.extrinsics.inverse();
    cameras
        .iter()
        .enumerate()
        .map(|(v, c)| {
            c.with_extrinsics(match v {
                0 => Extrinsics::default(),
                _ => c.extrinsics.after(&from_first),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use monohand_media::video::MetadataValue;
    use monohand_vision::image_io::PhotoFocal;

    #[test]
    fn a_calibration_outside_the_real_fields_of_view_is_used_with_its_reason() {
        let tele = Camera::centred(16_000.0, 640, 480).unwrap();
        let mut choice = CameraChoice::new(vec![tele]);
        let notes = choice.take_notes();
        assert_eq!(notes.len(), 1, "{notes:?}");
        // About the calibration given, not about a camera chosen for want of one.
        assert_eq!(notes[0].topic, NoteTopic::Calibration);
        assert!(
            notes[0]
                .message
                .starts_with("camera 1: the calibration gives a 2.3 degree"),
            "{}",
            notes[0]
        );
        // A first camera with extrinsics is said too: the joints are in another frame.
        let mut moved = tele;
        moved.extrinsics.translation.x = 100.0;
        let notes = calibration_notes(&[moved]);
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(notes[0].message.contains("the first camera has extrinsics"));
        choice
            .camera_for(&[Some((640, 480))], &StatedCamera::None)
            .unwrap();
        assert_eq!(choice.cameras(), &[tele]);
        let o = &choice.origins[0];
        assert_eq!(o.source, CameraSource::File);
        assert!(o
            .reason
            .as_deref()
            .is_some_and(|r| r.contains("used as given")));
        // Scaled, it keeps both reasons.
        choice
            .camera_for(&[Some((320, 240))], &StatedCamera::None)
            .unwrap();
        let o = &choice.origins[0];
        assert_eq!(o.source, CameraSource::FileScaled);
        let r = o.reason.as_deref().unwrap();
        assert!(
            r.contains("scaled by 0.5000") && r.contains("2.3 degree"),
            "{r}"
        );
    }

    #[test]
    fn photos_get_the_exif_camera_or_the_generic_one_with_the_reason() {
        let mut choice = CameraChoice::new(Vec::new());
        let db = StatedCamera::from(ExifFocal::Used(PhotoFocal {
            px: 2072.9,
            source: "EXIF FocalLength 88 mm on the Canon EOS 5DS R's 36 mm wide sensor".into(),
            sensor_width_mm: Some(36.0),
            fallback: Some("the photo was resized".into()),
        }));
        choice.camera_for(&[Some((848, 565))], &db).unwrap();
        assert_eq!(choice.cameras()[0].intrinsics.fx, 2072.9);
        assert_eq!(
            choice.origins,
            [CameraOrigin::new(
                CameraSource::ExifSensorDb,
                Some("the photo was resized".into())
            )]
        );
        let refused = StatedCamera::from(ExifFocal::Refused("a 2.3 degree field of view".into()));
        choice.camera_for(&[Some((848, 565))], &refused).unwrap();
        assert_eq!(choice.cameras()[0], Camera::generic(848, 565).unwrap());
        assert_eq!(choice.origins[0].source, CameraSource::Generic);
        assert_eq!(
            choice.origins[0].reason.as_deref(),
            Some("the EXIF focal length was not used: a 2.3 degree field of view")
        );
        choice
            .camera_for(&[Some((640, 480))], &StatedCamera::None)
            .unwrap();
        assert_eq!(
            choice.origins,
            [CameraOrigin::new(CameraSource::Generic, None)]
        );
        // Each kind said once: the database's camera, the refusal, the generic guess.
        choice.camera_for(&[Some((640, 480))], &refused).unwrap();
        let notes: Vec<String> = choice.take_notes().into_iter().map(|n| n.message).collect();
        assert_eq!(notes.len(), 3, "{notes:?}");
        assert!(
            notes[0].contains("fx = fy = 2072.9 px for 848x565"),
            "{}",
            notes[0]
        );
        assert!(
            notes[1].starts_with("the EXIF focal length was not used"),
            "{}",
            notes[1]
        );
        assert!(
            notes[2].starts_with("assuming a generic camera for 640x480"),
            "{}",
            notes[2]
        );
    }

    fn iphone(focal: MetadataValue) -> StatedCamera {
        StatedCamera::QuickTime(std::sync::Arc::new(VideoCameraTags {
            focal_35mm: Some(focal),
            lens_model: Some("iPhone 15 Pro back camera 6.765mm f/1.78".into()),
            make: Some("Apple".into()),
            model: Some("iPhone 15 Pro".into()),
        }))
    }

    /// A video's stated 35 mm equivalent spans the frame's diagonal, upright or not; an
    /// implausible or unreadable one falls back to the generic camera with why; a
    /// calibration wins over it.
    #[test]
    fn videos_get_the_camera_their_metadata_states_checked_as_photos_are() {
        let mut choice = CameraChoice::new(Vec::new());
        let f26 = 26.0 * 800.0 / 36f64.hypot(24.0);
        for size in [(640, 480), (480, 640)] {
            choice
                .camera_for(&[Some(size)], &iphone(MetadataValue::Integer(26)))
                .unwrap();
            let k = choice.cameras()[0].intrinsics;
            assert!((k.fx - f26).abs() < 1e-9 && k.fy == k.fx, "{k:?}");
            assert_eq!((k.width, k.height), size);
            assert_eq!(
                choice.origins,
                [CameraOrigin::new(CameraSource::VideoMetadata, None)]
            );
        }
        for (value, why) in [
            (
                MetadataValue::Integer(3000),
                "the video's focal length was not used: QuickTime focal_length.35mm_equivalent \
                 3000 mm (Apple iPhone 15 Pro, lens \"iPhone 15 Pro back camera 6.765mm \
                 f/1.78\") gives fx 55470 px for 640x480, a 0.7 degree",
            ),
            (
                MetadataValue::Text("wide".into()),
                "the video's focal length was not used: QuickTime \
                 focal_length.35mm_equivalent is \"wide\", not a focal length in mm",
            ),
        ] {
            choice
                .camera_for(&[Some((640, 480))], &iphone(value))
                .unwrap();
            assert_eq!(choice.cameras(), [Camera::generic(640, 480).unwrap()]);
            assert_eq!(choice.origins[0].source, CameraSource::Generic);
            let reason = choice.origins[0].reason.clone().unwrap();
            assert!(reason.starts_with(why), "{reason}");
        }
        let notes: Vec<String> = choice.take_notes().into_iter().map(|n| n.message).collect();
        assert_eq!(notes.len(), 2, "each kind once: {notes:?}");
        assert!(
            notes[0].starts_with(
                "the camera comes from the video's QuickTime focal_length.35mm_equivalent 26 \
                 mm (Apple iPhone 15 Pro, lens \"iPhone 15 Pro back camera 6.765mm f/1.78\"): \
                 fx = fy = 480.7 px for 640x480 (67.3 degree horizontal field of view"
            ),
            "{}",
            notes[0]
        );
        assert!(
            notes[1].contains(
                "; assuming a generic camera for 640x480 (60 degree horizontal \
                               field of view) instead"
            ),
            "{}",
            notes[1]
        );
        let given = Camera::centred(500.0, 640, 480).unwrap();
        let mut calibrated = CameraChoice::new(vec![given]);
        calibrated
            .camera_for(&[Some((640, 480))], &iphone(MetadataValue::Integer(26)))
            .unwrap();
        assert_eq!(calibrated.cameras(), [given]);
        assert_eq!(calibrated.origins[0].source, CameraSource::File);
    }
}
