//! The camera of each view, frame by frame: the calibrations the user gave (scaled to the
//! frames' size when it differs and has the same shape), or without them a camera per image
//! from the focal length its file states (EXIF), else the generic 60 degree guess; each
//! kind said once.

use crate::frame::{CameraError, CameraOrigin};
use crate::notes::{Note, NoteTopic};
use monohand_core::camera::Camera;
use monohand_io::jsonl::CameraSource;
use monohand_vision::image_io::ExifFocal;

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

impl CameraChoice {
    /// The choice for these calibrations (checked by the caller), with a note for each
    /// whose field of view is outside 5-150 degrees.
    pub(crate) fn new(cameras: Vec<Camera>) -> CameraChoice {
        let calibrated_fov: Vec<Option<String>> = cameras
            .iter()
            .map(|c| {
                c.implausible_field_of_view().map(|why| {
                    format!(
                        "the calibration gives {why}; used as given, since it is the user's own"
                    )
                })
            })
            .collect();
        let mut notes = Vec::new();
        for (v, why) in calibrated_fov.iter().enumerate() {
            if let Some(why) = why {
                notes.push(Note::new(
                    NoteTopic::Camera,
                    format!("camera {}: {why}", v + 1),
                ));
            }
        }
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
    /// focal length its file states, else the generic guess; with them, the calibrations,
    /// scaled to the frames' size when it differs and has the same shape (another shape is
    /// the error).
    pub(crate) fn camera_for(
        &mut self,
        sizes: &[Option<(u32, u32)>],
        focal: &ExifFocal,
    ) -> Result<(), CameraError> {
        if self.calibrated.is_empty() {
            let Some(&Some((w, h))) = sizes.first() else {
                return Ok(());
            };
            return self.photo_camera(w, h, focal);
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
        let generic = || Camera::generic(w, h);
        let (cam, origin) = match focal {
            ExifFocal::Used(f) => {
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
                        2.0 * (0.5 * w as f64 / f.px).atan().to_degrees()
                    ),
                );
                (cam, CameraOrigin::new(source, f.fallback.clone()))
            }
            ExifFocal::Refused(why) => {
                let reason = format!("the EXIF focal length was not used: {why}");
                self.say_once(
                    "generic, EXIF refused".into(),
                    format!(
                        "{reason}; assuming a generic camera for {w}x{h} (60 degree horizontal \
                         field of view) instead; absolute depth is only as right as this guess \
                         (docs/calibration.md)"
                    ),
                );
                (
                    generic()?,
                    CameraOrigin::new(CameraSource::Generic, Some(reason)),
                )
            }
            ExifFocal::None => {
                self.say_once(
                    "generic".into(),
                    format!(
                        "assuming a generic camera for {w}x{h} (60 degree horizontal field of \
                         view); absolute depth is only as right as this guess \
                         (docs/calibration.md)"
                    ),
                );
                (generic()?, CameraOrigin::new(CameraSource::Generic, None))
            }
        };
        self.cameras = vec![cam];
        self.origins = vec![origin];
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use monohand_vision::image_io::PhotoFocal;

    #[test]
    fn a_calibration_outside_the_real_fields_of_view_is_used_with_its_reason() {
        let tele = Camera::centred(16_000.0, 640, 480).unwrap();
        let mut choice = CameraChoice::new(vec![tele]);
        let notes = choice.take_notes();
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0]
                .message
                .starts_with("camera 1: the calibration gives a 2.3 degree"),
            "{}",
            notes[0]
        );
        choice
            .camera_for(&[Some((640, 480))], &ExifFocal::None)
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
            .camera_for(&[Some((320, 240))], &ExifFocal::None)
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
        let db = ExifFocal::Used(PhotoFocal {
            px: 2072.9,
            source: "EXIF FocalLength 88 mm on the Canon EOS 5DS R's 36 mm wide sensor".into(),
            sensor_width_mm: Some(36.0),
            fallback: Some("the photo was resized".into()),
        });
        choice.camera_for(&[Some((848, 565))], &db).unwrap();
        assert_eq!(choice.cameras()[0].intrinsics.fx, 2072.9);
        assert_eq!(
            choice.origins,
            [CameraOrigin::new(
                CameraSource::ExifSensorDb,
                Some("the photo was resized".into())
            )]
        );
        let refused = ExifFocal::Refused("a 2.3 degree field of view".into());
        choice.camera_for(&[Some((848, 565))], &refused).unwrap();
        assert_eq!(choice.cameras()[0], Camera::generic(848, 565).unwrap());
        assert_eq!(choice.origins[0].source, CameraSource::Generic);
        assert_eq!(
            choice.origins[0].reason.as_deref(),
            Some("the EXIF focal length was not used: a 2.3 degree field of view")
        );
        choice
            .camera_for(&[Some((640, 480))], &ExifFocal::None)
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
}
