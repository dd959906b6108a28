//! Reading images: format sniffed from the content (a WebP named `.jpg` still decodes), EXIF
//! orientation applied, every pixel format (8/16-bit, grey, RGBA, CMYK JPEG) converted to 8-bit RGB.
//!
//! [`load_photo`] also reads the focal length a camera wrote into the EXIF ([`PhotoFocal`]), so
//! that a photo without a calibration still gets its own field of view.

use std::io::Cursor;
use std::path::Path;

use image::{DynamicImage, ImageDecoder, ImageReader, RgbImage};

use crate::error::{Result, VisionError};

/// Smallest accepted side length in pixels: anything smaller cannot show a detectable hand.
pub const MIN_SIDE: u32 = 16;

/// The largest image decoded, in pixels (2^27, about 134 megapixels: a 108-megapixel phone
/// photo passes; its 8-bit RGB copy takes 3 bytes per pixel, 402 MB at the limit). A larger
/// image is refused before any pixel is decoded, with this limit in the message.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 27;

/// File extensions (lower-case) treated as images by [`images_in_folder`].
pub const IMAGE_EXTENSIONS: &[&str] = &["jpg", "jpeg", "png", "webp"];

/// Image files directly inside `dir`, sorted by file name (the `frame` order of
/// `monohand detect FOLDER`). Selection is by extension; content is checked when decoding.
pub fn images_in_folder(dir: &Path) -> Result<Vec<std::path::PathBuf>> {
    let io = |source| VisionError::ImageRead {
        path: dir.into(),
        source,
    };
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .map_err(io)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
        })
        .collect();
    files.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
    Ok(files)
}

/// Reads and decodes an image file (see the module docs).
pub fn load_rgb(path: &Path) -> Result<RgbImage> {
    load_photo(path).map(|p| p.image)
}

/// Decodes an in-memory encoded image (JPEG, PNG or WebP); `what` names it in errors.
pub fn decode_rgb(bytes: &[u8], what: &str) -> Result<RgbImage> {
    decode_photo(bytes, what).map(|p| p.image)
}

/// A decoded photo and the focal length its EXIF states, if any.
#[derive(Clone, Debug)]
pub struct Photo {
    /// The pixels, upright (EXIF orientation applied), 8-bit RGB.
    pub image: RgbImage,
    /// The focal length from the EXIF in pixels of `image`, or why the one the EXIF states
    /// was not used (see [`PhotoFocal`]).
    pub focal: ExifFocal,
}

/// What a photo's EXIF gave for its camera.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum ExifFocal {
    /// No focal length in the file (or no file: a video's frames).
    #[default]
    None,
    /// A focal length that passed the checks ([`PhotoFocal`]).
    Used(PhotoFocal),
    /// The file states a focal length but none of its readings passed the checks: why,
    /// for the user (the camera then falls back to the generic guess).
    Refused(String),
}

impl ExifFocal {
    /// The focal length used, if any.
    pub fn used(&self) -> Option<&PhotoFocal> {
        match self {
            ExifFocal::Used(f) => Some(f),
            _ => None,
        }
    }

    /// Why the stated focal length was not used, if it was not.
    pub fn refused(&self) -> Option<&str> {
        match self {
            ExifFocal::Refused(why) => Some(why),
            _ => None,
        }
    }
}

/// A focal length in pixels, read from a photo's EXIF and checked.
///
/// The readings, in order of preference; the first that passes the checks is used:
/// 1. `FocalLengthIn35mmFilm` (tag 0xA405, what phones write): the focal length that gives
///    a 36 x 24 mm frame the same angle of view. By its definition (CIPA DC-008) the angle is
///    the diagonal's, so `px = f35 * diagonal_px / 43.27` with 43.27 mm the diagonal of
///    36 x 24. Relative to the frame, it survives resizing. Checked against `FocalLength`
///    in mm where both are present: their ratio (divided by any `DigitalZoomRatio`) is the
///    sensor's crop factor, which is between [`CROP_FACTORS`]'s ends for every camera.
/// 2. `FocalLength` (0x920A) in mm and the sensor's width from the database by `Make` and
///    `Model` ([`crate::sensor_db`]): `px = f_mm * longer side px / sensor width mm`, times
///    any `DigitalZoomRatio`. It survives resizing too.
/// 3. `FocalLength` in mm with the sensor's `FocalPlaneXResolution` (0xA20E, pixels per
///    `FocalPlaneResolutionUnit` 0xA210: inch, cm, mm or µm). This resolution is the
///    sensor's own: it holds for the file as the camera wrote it, so it is scaled by the
///    stored width over `PixelXDimension` (0xA002) when the two differ, and is wrong for a
///    copy resized by software that rewrote `PixelXDimension` or dropped it (the sensor
///    width it implies, `width px / resolution`, is then too small).
///
/// Every reading must give a field of view within
/// [`monohand_core::camera::PLAUSIBLE_FOV_DEG`] (5-150 degrees across the longer side).
///
/// `PixelXDimension` and `PixelYDimension` say which frame the tags describe: an image of
/// the same shape is that frame resized; one of another shape with a side of the same
/// length was cropped without resizing, and the readings are for the uncropped frame,
/// whose pixels are this image's; one of another shape with no side in common was cropped
/// and resized, and no reading can be placed in it (refused). All readings assume square
/// pixels and that the frame the camera wrote spans the sensor's width.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotoFocal {
    /// Focal length in pixels (the same on both axes).
    pub px: f64,
    /// The tags it came from, for the user (for example `FocalLengthIn35mmFilm 26 mm`).
    pub source: String,
    /// The sensor width from the database, mm, when the focal came from it (reading 2).
    pub sensor_width_mm: Option<f64>,
    /// Why a reading ranked before this one was not used, when one was stated.
    pub fallback: Option<String>,
}

impl PhotoFocal {
    /// 35 mm-equivalent focal lengths taken as real, in mm: from a 4 mm fisheye-like
    /// wide angle (about 157 degrees across the diagonal) to a 2000 mm telephoto. The field
    /// of view check ([`monohand_core::camera::PLAUSIBLE_FOV_DEG`]) is narrower.
    pub const PLAUSIBLE_35MM: std::ops::RangeInclusive<f64> = 4.0..=2000.0;

    /// The 35 mm-equivalent focal length of this focal for an image of this size, mm.
    pub fn equivalent_35mm(&self, width: u32, height: u32) -> f64 {
        self.px * DIAGONAL_35MM / (width as f64).hypot(height as f64)
    }
}

/// Crop factors (the 35 mm frame's diagonal over the sensor's) of real cameras: from
/// 0.5 (a sensor of 87 mm diagonal, larger than any digital medium format) to 15 (2.9 mm,
/// smaller than any phone's 1/5" sensor).
pub const CROP_FACTORS: std::ops::RangeInclusive<f64> = 0.5..=15.0;

/// The tags of a photo's EXIF that say its camera (read by [`decode_photo`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExifTags {
    /// `Make` (0x010F).
    pub make: Option<String>,
    /// `Model` (0x0110).
    pub model: Option<String>,
    /// `FocalLength` (0x920A), mm.
    pub focal_mm: Option<f64>,
    /// `FocalLengthIn35mmFilm` (0xA405), mm; absent when 0 ("unknown").
    pub focal_35mm: Option<f64>,
    /// `FocalPlaneXResolution` (0xA20E) in pixels per mm (`FocalPlaneResolutionUnit`
    /// applied), and as the file writes it (for example `2413.33 pixels per cm`).
    pub focal_plane: Option<(f64, String)>,
    /// `PixelXDimension` and `PixelYDimension` (0xA002, 0xA003): the size of the image the
    /// tags were written for, in its stored orientation (the height may be missing).
    pub pixel_dimensions: Option<(f64, Option<f64>)>,
    /// `DigitalZoomRatio` (0xA404), when over 1.
    pub digital_zoom: Option<f64>,
}

impl ExifTags {
    /// The camera's name for the user: `Make Model`, the make once (`Canon EOS 5DS R`).
    pub fn camera_name(&self) -> Option<String> {
        let model = self.model.as_deref()?.trim();
        match self.make.as_deref().map(str::trim) {
            Some(make) if !model.to_lowercase().starts_with(&make.to_lowercase()) => {
                Some(format!("{make} {model}"))
            }
            _ => Some(model.to_string()),
        }
    }
}

/// Why the camera tags of an EXIF block could not be read ([`read_exif_tags`]).
#[derive(Debug, thiserror::Error)]
pub enum ExifError {
    /// The block is not readable EXIF.
    #[error("unreadable EXIF: {0}")]
    Unreadable(#[source] exif::Error),
    /// `FocalPlaneResolutionUnit` is not one of the standard's lengths.
    #[error("FocalPlaneResolutionUnit {0} is not a length")]
    FocalPlaneUnit(u32),
}

/// Reads the camera tags of a raw EXIF (TIFF) block; `Err`: unreadable, or a focal plane
/// unit that is not a length.
pub fn read_exif_tags(raw: Vec<u8>) -> std::result::Result<ExifTags, ExifError> {
    use exif::{In, Tag};
    let exif = exif::Reader::new()
        .read_raw(raw)
        .map_err(ExifError::Unreadable)?;
    let number = |tag: Tag| -> Option<f64> {
        let field = exif.get_field(tag, In::PRIMARY)?;
        let v = match &field.value {
            exif::Value::Rational(v) => v.first().map(|r| r.to_f64()),
            exif::Value::SRational(v) => v.first().map(|r| r.to_f64()),
            other => other.get_uint(0).map(f64::from),
        }?;
        v.is_finite().then_some(v)
    };
    let text = |tag: Tag| -> Option<String> {
        let field = exif.get_field(tag, In::PRIMARY)?;
        let exif::Value::Ascii(parts) = &field.value else {
            return None;
        };
        let s: String = parts
            .first()?
            .iter()
            .take_while(|&&b| b != 0)
            .map(|&b| char::from(b))
            .collect();
        let s = s.trim().to_string();
        (!s.is_empty()).then_some(s)
    };
    let focal_plane = match number(Tag::FocalPlaneXResolution).filter(|&r| r > 0.0) {
        None => None,
        Some(res) => {
            // Pixels per unit on the sensor; the unit is the inch when the tag is absent.
            let (unit_mm, unit) =
                match number(Tag::FocalPlaneResolutionUnit).map_or(2, |u| u as u32) {
                    2 => (25.4, "inch"),
                    3 => (10.0, "cm"),
                    4 => (1.0, "mm"),
                    5 => (1e-3, "µm"),
                    u => return Err(ExifError::FocalPlaneUnit(u)),
                };
            Some((res / unit_mm, format!("{} pixels per {unit}", round2(res))))
        }
    };
    let pixel_dimensions = number(Tag::PixelXDimension)
        .filter(|&x| x > 0.0)
        .map(|x| (x, number(Tag::PixelYDimension).filter(|&y| y > 0.0)));
    Ok(ExifTags {
        make: text(Tag::Make),
        model: text(Tag::Model),
        focal_mm: number(Tag::FocalLength).filter(|&f| f > 0.0),
        // 0 means "unknown" in the standard.
        focal_35mm: number(Tag::FocalLengthIn35mmFilm).filter(|&f| f > 0.0),
        focal_plane,
        pixel_dimensions,
        digital_zoom: number(Tag::DigitalZoomRatio).filter(|&z| z > 1.0),
    })
}

/// A number as the user wrote it, to two decimals at most (`2413.33`, `88`).
fn round2(v: f64) -> String {
    let r = (v * 100.0).round() / 100.0;
    format!("{r}")
}

/// The frame the EXIF tags describe, in pixels of the image at hand.
struct TaggedFrame {
    /// Its size in pixels of this image (larger than the image when it was cropped).
    width: f64,
    height: f64,
    /// The scale from the file the camera wrote to this one (1 unless resized).
    scale: f64,
    /// How the image relates to the frame, for the user (`None`: it is the frame).
    note: Option<String>,
}

/// Where this image (stored `sw` x `sh`, before the EXIF orientation) sits in the frame its
/// tags describe (`PixelXDimension` x `PixelYDimension`, in either orientation).
fn tagged_frame(
    dims: Option<(f64, Option<f64>)>,
    sw: u32,
    sh: u32,
) -> std::result::Result<TaggedFrame, String> {
    let (w, h) = (f64::from(sw), f64::from(sh));
    let (px, py) = match dims {
        None => {
            return Ok(TaggedFrame {
                width: w,
                height: h,
                scale: 1.0,
                note: None,
            })
        }
        // Without the height, the width alone: taken as the same shape.
        Some((px, None)) => (px, px * h / w),
        Some((px, Some(py))) => (px, py),
    };
    // The same shape up to a pixel of rounding: the frame, resized (or not).
    let same_shape =
        |px: f64, py: f64| (py * w / px - h).abs() <= 1.0 || (px * h / py - w).abs() <= 1.0;
    // Cropped without resizing: inside the frame, one side whole.
    let cropped = |px: f64, py: f64| w <= px && h <= py && (w == px || h == py);
    // Some writers give the upright size: the tags as written first, then turned.
    for (px, py) in [(px, py), (py, px)] {
        if same_shape(px, py) {
            let scale = w / px;
            let note = (scale != 1.0).then(|| {
                format!(
                    "the image is {sw}x{sh}, resized from the {px}x{py} the EXIF was written for"
                )
            });
            return Ok(TaggedFrame {
                width: w,
                height: h,
                scale,
                note,
            });
        }
    }
    for (px, py) in [(px, py), (py, px)] {
        if cropped(px, py) {
            return Ok(TaggedFrame {
                width: px,
                height: py,
                scale: 1.0,
                note: Some(format!(
                    "the image is {sw}x{sh}, cropped from the {px}x{py} frame the EXIF describes"
                )),
            });
        }
    }
    Err(format!(
        "the image is {sw}x{sh} but its EXIF describes a {px}x{py} frame, another shape with \
         no side in common: it was cropped and resized, so where the lens's frame lies in it \
         is unknown"
    ))
}

/// The focal length in pixels of an image stored `stored` (width, height, before the EXIF
/// orientation) and `upright` after it, from its EXIF camera tags (see [`PhotoFocal`]).
pub fn focal_from_tags(tags: &ExifTags, stored: (u32, u32), upright: (u32, u32)) -> ExifFocal {
    if tags.focal_35mm.is_none() && tags.focal_mm.is_none() {
        return ExifFocal::None;
    }
    let frame = match tagged_frame(tags.pixel_dimensions, stored.0, stored.1) {
        Ok(f) => f,
        Err(why) => return ExifFocal::Refused(why),
    };
    let reading = FocalReading::new(tags, frame, upright);
    // Why each reading tried was not used, in order.
    let mut refused: Vec<String> = Vec::new();
    // 1. The 35 mm equivalent.
    if let Some(used) = reading.try_35mm(tags, &mut refused) {
        return used;
    }
    let Some(f_mm) = tags.focal_mm else {
        return ExifFocal::Refused(refused.join("; "));
    };
    // What the focal plane resolution implies, for 2. and 3.
    let plane = reading.focal_plane(tags, f_mm);
    // 2. The sensor database.
    let entry = match (&tags.make, &tags.model) {
        (Some(make), Some(model)) => crate::sensor_db::lookup(make, model),
        _ => None,
    };
    if let Some(e) = entry {
        if let Some(used) = reading.try_sensor_db(tags, f_mm, e.width_mm, &plane, &mut refused) {
            return used;
        }
    }
    // 3. The focal plane resolution.
    if let Some(plane) = plane {
        if let Some(used) = reading.try_focal_plane(f_mm, plane, &mut refused) {
            return used;
        }
    } else if entry.is_none() && tags.focal_35mm.is_none() {
        refused.push(format!(
            "EXIF FocalLength {} mm, but nothing says the sensor's size: no \
             FocalLengthIn35mmFilm, no FocalPlaneXResolution, and {} in the sensor database",
            round2(f_mm),
            match tags.camera_name() {
                Some(name) => format!("the {name} is not"),
                None => "no Make and Model to look up".into(),
            }
        ));
    }
    ExifFocal::Refused(refused.join("; "))
}

/// What the focal plane resolution implies: the focal length in pixels, the sensor width
/// it implies for the image's frame (mm), and the tag as written.
type PlaneReading<'a> = (f64, f64, &'a String);

/// The image a focal length is read for, and the readings of [`focal_from_tags`] in turn.
struct FocalReading {
    /// The frame the tags describe.
    frame: TaggedFrame,
    /// The image's upright size, pixels.
    w: u32,
    h: u32,
    /// `DigitalZoomRatio` (1 without it), and as said to the user (empty without it).
    zoom: f64,
    zoom_text: String,
    /// The frame's diagonal and longer side, pixels.
    diagonal: f64,
    longer: f64,
}

impl FocalReading {
    fn new(tags: &ExifTags, frame: TaggedFrame, upright: (u32, u32)) -> FocalReading {
        let (w, h) = upright;
        let zoom = tags.digital_zoom.unwrap_or(1.0);
        let zoom_text = match tags.digital_zoom {
            Some(z) => format!(" with DigitalZoomRatio {}", round2(z)),
            None => String::new(),
        };
        let diagonal = frame.width.hypot(frame.height);
        let longer = frame.width.max(frame.height);
        FocalReading {
            frame,
            w,
            h,
            zoom,
            zoom_text,
            diagonal,
            longer,
        }
    }

    /// Whether `px` (read from `source`) makes a plausible camera for the image, else why not.
    fn check(&self, px: f64, source: &str) -> std::result::Result<(), String> {
        check_focal(px, source, (self.w, self.h), self.diagonal).map_err(|e| e.0)
    }

    /// The focal `px` used, with the readings `refused` before it and the frame's note.
    fn done(&self, px: f64, source: String, sensor: Option<f64>, refused: &[String]) -> ExifFocal {
        let mut why: Vec<String> = refused.to_vec();
        if let Some(n) = &self.frame.note {
            why.push(n.clone());
        }
        ExifFocal::Used(PhotoFocal {
            px,
            source,
            sensor_width_mm: sensor,
            fallback: (!why.is_empty()).then(|| why.join("; ")),
        })
    }

    /// Reading 1, the 35 mm equivalent: the focal used, or `None` with why not in `refused`.
    fn try_35mm(&self, tags: &ExifTags, refused: &mut Vec<String>) -> Option<ExifFocal> {
        let f35 = tags.focal_35mm?;
        let source = format!("EXIF FocalLengthIn35mmFilm {} mm", round2(f35));
        let px = f35 * self.diagonal / DIAGONAL_35MM;
        let crop = tags.focal_mm.map(|f| f35 / (f * self.zoom));
        match crop.filter(|c| !CROP_FACTORS.contains(c)) {
            Some(c) => refused.push(format!(
                "{source} against FocalLength {} mm{} is a crop factor of {c:.2}, a \
                 sensor {:.1} mm across, outside the {}-{} of real cameras (an editor's value?)",
                round2(tags.focal_mm.unwrap_or_default()),
                self.zoom_text,
                DIAGONAL_35MM / c,
                CROP_FACTORS.start(),
                CROP_FACTORS.end()
            )),
            None => match self.check(px, &source) {
                Ok(()) => return Some(self.done(px, source, None, refused)),
                Err(why) => refused.push(why),
            },
        }
        None
    }

    /// What the focal plane resolution implies for the focal length `f_mm`, if stated.
    fn focal_plane<'a>(&self, tags: &'a ExifTags, f_mm: f64) -> Option<PlaneReading<'a>> {
        tags.focal_plane.as_ref().map(|(per_mm, text)| {
            let px = f_mm * self.zoom * per_mm * self.frame.scale;
            // The sensor width it implies for this image's frame.
            let width_mm = self.frame.width / (per_mm * self.frame.scale);
            (px, width_mm, text)
        })
    }

    /// Reading 2, the sensor database's width `sensor_mm`: the focal used, or `None` with
    /// why not in `refused`.
    fn try_sensor_db(
        &self,
        tags: &ExifTags,
        f_mm: f64,
        sensor_mm: f64,
        plane: &Option<PlaneReading<'_>>,
        refused: &mut Vec<String>,
    ) -> Option<ExifFocal> {
        let name = tags.camera_name().unwrap_or_default();
        let source = format!(
            "EXIF FocalLength {} mm{} on the {name}'s {} mm wide sensor (sensor database)",
            round2(f_mm),
            self.zoom_text,
            round2(sensor_mm)
        );
        let px = f_mm * self.zoom * self.longer / sensor_mm;
        match self.check(px, &source) {
            Ok(()) => {
                let mut why = refused.clone();
                if tags.focal_35mm.is_none() {
                    why.push("no FocalLengthIn35mmFilm".into());
                }
                if let Some((_, width_mm, text)) = plane {
                    if (width_mm / sensor_mm - 1.0).abs() > 0.05 {
                        why.push(format!(
                            "FocalPlaneXResolution {text} implies a sensor {width_mm:.1} mm wide \
                             for this {}-pixel-wide frame, not {} mm: the photo was resized",
                            self.frame.width,
                            round2(sensor_mm)
                        ));
                    }
                }
                Some(self.done(px, source, Some(sensor_mm), &why))
            }
            Err(why) => {
                refused.push(why);
                None
            }
        }
    }

    /// Reading 3, the focal plane resolution: the focal used, or `None` with why not in
    /// `refused`.
    fn try_focal_plane(
        &self,
        f_mm: f64,
        (px, width_mm, text): PlaneReading<'_>,
        refused: &mut Vec<String>,
    ) -> Option<ExifFocal> {
        let source = format!(
            "EXIF FocalLength {} mm{} at {text} on the sensor",
            round2(f_mm),
            self.zoom_text
        );
        match self.check(px, &source) {
            Ok(()) => Some(self.done(px, source, None, refused)),
            Err(why) => {
                refused.push(format!(
                    "{why} (read against this {}-pixel-wide frame it implies a sensor \
                     {width_mm:.1} mm wide: was the photo resized?)",
                    self.frame.width
                ));
                None
            }
        }
    }
}

/// Diagonal of a 36 x 24 mm frame, mm.
const DIAGONAL_35MM: f64 = 43.266_615_305_567_875;

/// Why a focal length does not make a plausible camera ([`focal_from_35mm`]): the reading
/// and the reason, for the user.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct FocalRefused(pub String);

/// Whether the focal length `px` (read from `source`) makes a plausible camera for an image
/// of `size` (width, height) whose lens's frame has a diagonal of `diagonal` pixels, else
/// why not: a field of view within [`monohand_core::camera::PLAUSIBLE_FOV_DEG`] and a 35 mm
/// equivalent within [`PhotoFocal::PLAUSIBLE_35MM`].
fn check_focal(
    px: f64,
    source: &str,
    (w, h): (u32, u32),
    diagonal: f64,
) -> std::result::Result<(), FocalRefused> {
    let refused = |why: String| Err(FocalRefused(why));
    let camera = match monohand_core::camera::Camera::centred(px, w, h) {
        Ok(c) => c,
        Err(e) => return refused(format!("{source}: {e}")),
    };
    let f35 = px * DIAGONAL_35MM / diagonal;
    if let Some(why) = camera.implausible_field_of_view() {
        return refused(format!("{source} gives fx {px:.0} px for {w}x{h}, {why}"));
    }
    if !PhotoFocal::PLAUSIBLE_35MM.contains(&f35) {
        return refused(format!(
            "{source} gives a 35 mm equivalent of {f35:.1} mm, outside {:?} mm",
            PhotoFocal::PLAUSIBLE_35MM
        ));
    }
    Ok(())
}

/// The focal length in pixels that a 35 mm-equivalent focal length of `f35` mm gives a
/// `width` x `height` frame, checked as a photo's `FocalLengthIn35mmFilm` is (see
/// [`PhotoFocal`]): `f35 * diagonal px / 43.27`, the 35 mm equivalent being defined on the
/// diagonal, with a field of view within [`monohand_core::camera::PLAUSIBLE_FOV_DEG`] and
/// `f35` within [`PhotoFocal::PLAUSIBLE_35MM`]. `source` names the reading in the refusal
/// (for a video's metadata, say). The frame must be the whole frame the lens saw, upright
/// or not (the diagonal is the same).
pub fn focal_from_35mm(
    f35: f64,
    source: &str,
    width: u32,
    height: u32,
) -> std::result::Result<f64, FocalRefused> {
    let diagonal = f64::from(width).hypot(f64::from(height));
    let px = f35 * diagonal / DIAGONAL_35MM;
    check_focal(px, source, (width, height), diagonal)?;
    Ok(px)
}

/// Reads and decodes a photo with its EXIF focal length (see the module docs).
pub fn load_photo(path: &Path) -> Result<Photo> {
    let bytes = std::fs::read(path).map_err(|source| VisionError::ImageRead {
        path: path.into(),
        source,
    })?;
    decode_photo(&bytes, &path.display().to_string())
}

/// Decodes an in-memory photo with its EXIF focal length; `what` names it in errors. A
/// damaged EXIF block is no error: the photo is decoded without a focal length.
pub fn decode_photo(bytes: &[u8], what: &str) -> Result<Photo> {
    let err = |reason: String| VisionError::ImageDecode {
        what: what.into(),
        reason,
    };
    let reader = ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| err(e.to_string()))?;
    if reader.format().is_none() {
        return Err(err(
            "unknown image format (supported: JPEG, PNG, WebP)".into()
        ));
    }
    let mut decoder = reader.into_decoder().map_err(|e| err(e.to_string()))?;
    let (stored_width, stored_height) = decoder.dimensions();
    if u64::from(stored_width) * u64::from(stored_height) > MAX_IMAGE_PIXELS {
        return Err(VisionError::ImageUnusable {
            what: what.into(),
            reason: format!(
                "{stored_width}x{stored_height} pixels is over the largest image monohand \
                 decodes, {:.0} megapixels (image_io::MAX_IMAGE_PIXELS); downscale it first",
                MAX_IMAGE_PIXELS as f64 / 1e6
            ),
        });
    }
    // Read before `orientation`, which may consume the same block.
    let exif = decoder.exif_metadata().ok().flatten();
    let orientation = decoder.orientation().map_err(|e| err(e.to_string()))?;
    let mut img = DynamicImage::from_decoder(decoder).map_err(|e| err(e.to_string()))?;
    img.apply_orientation(orientation);
    let rgb = img.into_rgb8();
    if rgb.width() < MIN_SIDE || rgb.height() < MIN_SIDE {
        return Err(VisionError::ImageUnusable {
            what: what.into(),
            reason: format!(
                "{}x{} pixels is too small to contain a hand (minimum {MIN_SIDE}x{MIN_SIDE})",
                rgb.width(),
                rgb.height()
            ),
        });
    }
    let focal = match exif.map(read_exif_tags) {
        None => ExifFocal::None,
        Some(Err(why)) => {
            // A damaged block says nothing: the photo is decoded without it.
            tracing::warn!("{what}: EXIF not read: {why}");
            ExifFocal::None
        }
        Some(Ok(tags)) => focal_from_tags(
            &tags,
            (stored_width, stored_height),
            (rgb.width(), rgb.height()),
        ),
    };
    Ok(Photo { image: rgb, focal })
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{ImageBuffer, ImageFormat, Luma, Rgba};

    fn encode(img: DynamicImage, fmt: ImageFormat) -> Vec<u8> {
        let mut buf = Cursor::new(Vec::new());
        img.write_to(&mut buf, fmt).expect("encode");
        buf.into_inner()
    }

    #[test]
    fn sixteen_bit_grey_png_becomes_rgb8() {
        let img = ImageBuffer::<Luma<u16>, _>::from_fn(20, 20, |x, _| Luma([(x * 3000) as u16]));
        let rgb = decode_rgb(
            &encode(DynamicImage::ImageLuma16(img), ImageFormat::Png),
            "t",
        )
        .expect("decode");
        assert_eq!(rgb.dimensions(), (20, 20));
        let p = rgb.get_pixel(10, 0);
        assert_eq!(p[0], p[1]);
        assert!((p[0] as i32 - 30000 * 255 / 65535).abs() <= 1);
    }

    #[test]
    fn folder_listing_is_sorted_and_filtered() {
        let dir = std::env::temp_dir().join(format!("monohand-folder-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        for n in ["b.PNG", "a.jpg", "c.txt", "d.webp"] {
            std::fs::write(dir.join(n), b"x").expect("write");
        }
        let names: Vec<_> = images_in_folder(&dir)
            .expect("list")
            .iter()
            .map(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .unwrap_or("")
                    .to_string()
            })
            .collect();
        assert_eq!(names, ["a.jpg", "b.PNG", "d.webp"]);
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn rgba_drops_alpha() {
        let img = ImageBuffer::<Rgba<u8>, _>::from_pixel(17, 18, Rgba([10, 20, 30, 0]));
        let rgb = decode_rgb(
            &encode(DynamicImage::ImageRgba8(img), ImageFormat::Png),
            "t",
        )
        .expect("decode");
        assert_eq!(rgb.get_pixel(0, 0).0, [10, 20, 30]);
    }

    #[test]
    fn tiny_and_corrupt_images_are_clear_errors() {
        let one = DynamicImage::ImageRgb8(RgbImage::new(1, 1));
        let e = decode_rgb(&encode(one, ImageFormat::Png), "one.png").expect_err("1x1");
        assert!(e.to_string().contains("too small"), "{e}");
        let e = decode_rgb(b"\xff\xd8\xff\xe0garbage", "bad.jpg").expect_err("corrupt");
        assert!(matches!(e, VisionError::ImageDecode { .. }), "{e}");
        let e = decode_rgb(b"hello world", "text.jpg").expect_err("not an image");
        assert!(e.to_string().contains("unknown image format"), "{e}");
    }

    /// A PNG chunk: length, type, data, CRC-32 of type and data.
    fn png_chunk(kind: &[u8; 4], data: &[u8]) -> Vec<u8> {
        let mut crc = 0xffff_ffffu32;
        for &byte in kind.iter().chain(data) {
            crc ^= u32::from(byte);
            for _ in 0..8 {
                crc = if crc & 1 == 1 {
                    (crc >> 1) ^ 0xedb8_8320
                } else {
                    crc >> 1
                };
            }
        }
        let mut out = (data.len() as u32).to_be_bytes().to_vec();
        out.extend_from_slice(kind);
        out.extend_from_slice(data);
        out.extend_from_slice(&(!crc).to_be_bytes());
        out
    }

    /// The header of an 8-bit RGB PNG of `w` x `h` pixels, with a stub of pixel data.
    fn png_header(w: u32, h: u32) -> Vec<u8> {
        let mut ihdr = w.to_be_bytes().to_vec();
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        png.extend(png_chunk(b"IHDR", &ihdr));
        png.extend(png_chunk(
            b"IDAT",
            &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
        ));
        png.extend(png_chunk(b"IEND", &[]));
        png
    }

    #[test]
    fn an_image_over_the_size_limit_is_refused_before_decoding() {
        // 60 000 x 40 000 pixels claimed by a 60-byte file: refused by its header, with the
        // limit named, before any allocation for its pixels.
        let e = decode_rgb(&png_header(60_000, 40_000), "huge.png").expect_err("too large");
        let msg = e.to_string();
        assert!(matches!(e, VisionError::ImageUnusable { .. }), "{msg}");
        assert!(
            msg.contains("60000x40000") && msg.contains("134 megapixels"),
            "{msg}"
        );
        // Just under the limit the header is accepted, and the stub of pixel data is the
        // error (a decode error, not the size).
        let e = decode_rgb(&png_header(16_384, 8_192), "big.png").expect_err("no pixels");
        assert!(matches!(e, VisionError::ImageDecode { .. }), "{e}");
    }

    #[test]
    fn a_35mm_equivalent_is_read_on_the_diagonal_and_checked() {
        // 26 mm on 640x480: the diagonal is 800 px, so 26 x 800 / 43.27 px, upright or not.
        let f = focal_from_35mm(26.0, "26 mm", 640, 480).expect("plausible");
        assert!(
            (f - 26.0 * 800.0 / 43.266_615_305_567_875).abs() < 1e-9,
            "{f}"
        );
        assert_eq!(focal_from_35mm(26.0, "26 mm", 480, 640), Ok(f));
        let e = focal_from_35mm(3000.0, "the video's 3000 mm", 160, 120).expect_err("too long");
        assert!(
            e.0.starts_with("the video's 3000 mm gives fx 13868 px for 160x120, a 0.7 degree"),
            "{e}"
        );
        let e = focal_from_35mm(0.0, "0 mm", 160, 120).expect_err("zero");
        assert!(e.0.starts_with("0 mm: "), "{e}");
        // 5 mm is 147.8 degrees across 160 px; 4.5 mm is 150.8, past 150, before the 4 mm floor of
        // equivalents.
        assert!(focal_from_35mm(5.0, "5 mm", 160, 120).is_ok());
        let e = focal_from_35mm(4.5, "4.5 mm", 160, 120).expect_err("too wide");
        assert!(e.0.contains("a 150.8 degree field of view"), "{e}");
    }
}
