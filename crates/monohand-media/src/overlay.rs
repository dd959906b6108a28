//! Drawing on [`RgbImage`]s: anti-aliased thick lines, circles, rectangles,
//! polygons (e.g. oriented boxes), a built-in 5x7 bitmap font for short
//! labels, and [`draw_hand`], which draws a detected hand skeleton and the
//! fitted 3D model projected back into the image.
//!
//! Every function clips to the image: shapes partly or wholly outside it, and
//! coordinates that are NaN or infinite, never panic (non-finite shapes are
//! skipped). Pixel centres are at integer coordinates, as in the keypoint files.
//!
//! ```
//! use monohand_media::overlay::{draw_line, draw_text, Pen};
//! use monohand_media::video::RgbImage;
//! let mut img = RgbImage::new(64, 32);
//! draw_line(&mut img, [2.0, 5.0], [40.0, 5.0], &Pen::new([255, 0, 0], 1.0));
//! assert_eq!(img.get_pixel(20, 5).0, [255, 0, 0]);
//! draw_text(&mut img, "R#3 0.97", [1.0, 10.0], 1, [255, 255, 255]);
//! ```

use crate::video::RgbImage;
use monohand_core::bbox::BBox;
use monohand_core::camera::Camera;
use monohand_core::hand_model::{HandSide, BONES, NUM_JOINTS, WRIST};
pub use monohand_io::palette::{side_color, Rgb, FINGER_COLORS};
use nalgebra::Vector3;

/// How to draw a line or outline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pen {
    /// The colour.
    pub color: Rgb,
    /// Line width, pixels.
    pub thickness: f64,
    /// Opacity in `[0, 1]` (1: opaque).
    pub opacity: f64,
    /// Smooth edges (partial coverage blended); off: each pixel is either painted or not.
    pub antialias: bool,
}

impl Pen {
    /// An opaque anti-aliased pen.
    pub fn new(color: Rgb, thickness: f64) -> Pen {
        Pen {
            color,
            thickness,
            opacity: 1.0,
            antialias: true,
        }
    }

    /// The same pen with another opacity.
    pub fn with_opacity(self, opacity: f64) -> Pen {
        Pen { opacity, ..self }
    }

    /// Coverage in `[0, 1]` of a pixel whose centre is `inside` pixels inside the
    /// shape's edge (negative: outside), scaled by the opacity.
    fn alpha(&self, inside: f64) -> f64 {
        let c = if self.antialias {
            (inside + 0.5).clamp(0.0, 1.0)
        } else if inside >= 0.0 {
            1.0
        } else {
            0.0
        };
        c * self.opacity.clamp(0.0, 1.0)
    }
}

/// Blends `color` over the pixel `(x, y)` with weight `alpha`; nothing outside the image.
pub fn blend_pixel(frame: &mut RgbImage, x: i64, y: i64, color: Rgb, alpha: f64) {
    let (Ok(x), Ok(y)) = (u32::try_from(x), u32::try_from(y)) else {
        return;
    };
    if alpha <= 0.0 {
        return;
    }
    let Some(px) = frame.get_pixel_mut_checked(x, y).map(|p| &mut p.0) else {
        return;
    };
    let a = alpha.min(1.0);
    for (p, &c) in px.iter_mut().zip(&color) {
        *p = (*p as f64 * (1.0 - a) + c as f64 * a).round() as u8;
    }
}

/// `v > 0` (false for NaN).
fn positive(v: f64) -> bool {
    v > 0.0
}

fn finite(p: [f64; 2]) -> bool {
    p[0].is_finite() && p[1].is_finite()
}

/// The rows `y0..=y1` of the image covering `[lo, hi]` (empty if outside).
#[allow(clippy::reversed_empty_ranges)]
fn rows(frame: &RgbImage, lo: f64, hi: f64) -> std::ops::RangeInclusive<i64> {
    let y0 = lo.floor().max(0.0);
    let y1 = hi.ceil().min(frame.height() as f64 - 1.0);
    if y0.is_nan() || y1.is_nan() || y0 > y1 {
        return 1..=0;
    }
    y0 as i64..=y1 as i64
}

/// The columns of the image covering `[lo, hi]`, as a clipped inclusive range.
#[allow(clippy::reversed_empty_ranges)]
fn cols(frame: &RgbImage, lo: f64, hi: f64) -> std::ops::RangeInclusive<i64> {
    let x0 = lo.floor().max(0.0);
    let x1 = hi.ceil().min(frame.width() as f64 - 1.0);
    if x0.is_nan() || x1.is_nan() || x0 > x1 {
        return 1..=0;
    }
    x0 as i64..=x1 as i64
}

/// Draws the segment `a`-`b` with round caps.
pub fn draw_line(frame: &mut RgbImage, a: [f64; 2], b: [f64; 2], pen: &Pen) {
    if !finite(a) || !finite(b) || !positive(pen.thickness) {
        return;
    }
    let r = pen.thickness / 2.0;
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let len = len2.sqrt();
    let m = r + 1.0;
    let (bx0, bx1) = (a[0].min(b[0]) - m, a[0].max(b[0]) + m);
    for y in rows(frame, a[1].min(b[1]) - m, a[1].max(b[1]) + m) {
        let py = y as f64;
        // The columns where the infinite band of half-width m crosses this row.
        let (mut lo, mut hi) = (bx0, bx1);
        if len > 0.0 && dy.abs() > 1e-12 {
            // |(-dy)(x - ax) + dx (y - ay)| / len <= m  <=>  x in [c - w, c + w]
            let c = a[0] + dx * (py - a[1]) / dy;
            let w = m * len / dy.abs();
            lo = lo.max(c - w);
            hi = hi.min(c + w);
        }
        for x in cols(frame, lo, hi) {
            let px = x as f64;
            let t = if len2 > 0.0 {
                (((px - a[0]) * dx + (py - a[1]) * dy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (qx, qy) = (a[0] + t * dx - px, a[1] + t * dy - py);
            let d = (qx * qx + qy * qy).sqrt();
            blend_pixel(frame, x, y, pen.color, pen.alpha(r - d));
        }
    }
}

/// Paints every pixel of the box (clipped) with `alpha(x, y)`.
fn paint(frame: &mut RgbImage, bbox: BBox, color: Rgb, alpha: impl Fn(f64, f64) -> f64) {
    if !bbox.is_finite() {
        return;
    }
    for y in rows(frame, bbox.y_min, bbox.y_max) {
        for x in cols(frame, bbox.x_min, bbox.x_max) {
            blend_pixel(frame, x, y, color, alpha(x as f64, y as f64));
        }
    }
}

/// Fills a disc of this radius (the pen's thickness is not used).
pub fn fill_circle(frame: &mut RgbImage, center: [f64; 2], radius: f64, pen: &Pen) {
    if !finite(center) || !positive(radius) {
        return;
    }
    let [cx, cy] = center;
    let m = radius + 1.0;
    paint(
        frame,
        BBox::from_centre_size(center, 2.0 * m, 2.0 * m),
        pen.color,
        |x, y| pen.alpha(radius - ((x - cx).powi(2) + (y - cy).powi(2)).sqrt()),
    );
}

/// Draws a circle outline (a ring of the pen's thickness centred on the radius).
pub fn draw_circle(frame: &mut RgbImage, center: [f64; 2], radius: f64, pen: &Pen) {
    if !finite(center) || !positive(radius) || !positive(pen.thickness) {
        return;
    }
    let [cx, cy] = center;
    let h = pen.thickness / 2.0;
    let m = radius + h + 1.0;
    paint(
        frame,
        BBox::from_centre_size(center, 2.0 * m, 2.0 * m),
        pen.color,
        |x, y| {
            let d = ((x - cx).powi(2) + (y - cy).powi(2)).sqrt();
            pen.alpha(h - (d - radius).abs())
        },
    );
}

/// Draws a closed polygon outline through `corners` (e.g. the 4 corners of an oriented box).
pub fn draw_polygon(frame: &mut RgbImage, corners: &[[f64; 2]], pen: &Pen) {
    for (i, &a) in corners.iter().enumerate() {
        let b = corners[(i + 1) % corners.len()];
        draw_line(frame, a, b, pen);
    }
}

/// Draws the outline of the axis-aligned box.
pub fn draw_rect(frame: &mut RgbImage, bbox: BBox, pen: &Pen) {
    let [x0, y0, x1, y1] = bbox.to_array();
    draw_polygon(frame, &[[x0, y0], [x1, y0], [x1, y1], [x0, y1]], pen);
}

/// Fills the pixels whose centres lie in the box.
pub fn fill_rect(frame: &mut RgbImage, bbox: BBox, color: Rgb, opacity: f64) {
    if !bbox.is_finite() || opacity.is_nan() || opacity <= 0.0 {
        return;
    }
    let a = opacity.min(1.0);
    // The pixels whose centres lie in the box; each channel's blend is one table
    // lookup (the same rounding as `blend_pixel`).
    let (xs, ys) = (
        cols(frame, bbox.x_min.ceil(), bbox.x_max.floor()),
        rows(frame, bbox.y_min.ceil(), bbox.y_max.floor()),
    );
    if xs.is_empty() || ys.is_empty() {
        return;
    }
    let table: [[u8; 256]; 3] = std::array::from_fn(|k| {
        std::array::from_fn(|p| (p as f64 * (1.0 - a) + color[k] as f64 * a).round() as u8)
    });
    let w = frame.width() as usize;
    let (x0, x1) = (*xs.start() as usize, *xs.end() as usize);
    let data: &mut [u8] = frame;
    for y in ys {
        let row = y as usize * w;
        let Some(px) = data.get_mut(3 * (row + x0)..3 * (row + x1 + 1)) else {
            return;
        };
        for p in px.chunks_exact_mut(3) {
            for (k, v) in p.iter_mut().enumerate() {
                *v = table[k][*v as usize];
            }
        }
    }
}

/// Width and height of one glyph cell of the font, before scaling.
pub const GLYPH_W: usize = 5;
/// Height of a glyph, before scaling.
pub const GLYPH_H: usize = 7;

/// The 5x7 bitmap of a character (rows top to bottom, bit 4 = left column);
/// lower case is drawn as upper case, unknown characters as `?`.
fn glyph(c: char) -> [u8; GLYPH_H] {
    match c.to_ascii_uppercase() {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'A' => [0x0E, 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11],
        'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
        'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
        ' ' => [0; GLYPH_H],
        '#' => [0x0A, 0x0A, 0x1F, 0x0A, 0x1F, 0x0A, 0x0A],
        '.' => [0, 0, 0, 0, 0, 0x0C, 0x0C],
        ',' => [0, 0, 0, 0, 0x0C, 0x04, 0x08],
        '-' => [0, 0, 0, 0x1F, 0, 0, 0],
        '+' => [0, 0x04, 0x04, 0x1F, 0x04, 0x04, 0],
        '=' => [0, 0, 0x1F, 0, 0x1F, 0, 0],
        ':' => [0, 0x0C, 0x0C, 0, 0x0C, 0x0C, 0],
        '/' => [0, 0x01, 0x02, 0x04, 0x08, 0x10, 0],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '_' => [0, 0, 0, 0, 0, 0, 0x1F],
        _ => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04],
    }
}

/// Size in pixels `(width, height)` of `text` drawn at this scale (one line;
/// each character is 6 x 8 cells including spacing).
pub fn text_size(text: &str, scale: usize) -> (usize, usize) {
    let n = text.chars().count();
    let s = scale.max(1);
    ((n * (GLYPH_W + 1)).saturating_sub(1) * s, GLYPH_H * s)
}

/// Draws one line of text with its top-left corner at `origin`, each font
/// pixel a `scale x scale` square. Returns the box drawn.
pub fn draw_text(
    frame: &mut RgbImage,
    text: &str,
    origin: [f64; 2],
    scale: usize,
    color: Rgb,
) -> BBox {
    let s = scale.max(1);
    let (w, h) = text_size(text, s);
    let bbox = BBox::new(
        origin[0],
        origin[1],
        origin[0] + w as f64,
        origin[1] + h as f64,
    );
    if !finite(origin) || origin[0].abs() > 1e9 || origin[1].abs() > 1e9 {
        return bbox;
    }
    let (ox, oy) = (origin[0].round() as i64, origin[1].round() as i64);
    for (i, c) in text.chars().enumerate() {
        let g = glyph(c);
        let cx = ox + (i * (GLYPH_W + 1) * s) as i64;
        for (row, bits) in g.iter().enumerate() {
            for col in 0..GLYPH_W {
                if bits & (0x10 >> col) == 0 {
                    continue;
                }
                for dy in 0..s {
                    for dx in 0..s {
                        let x = cx + (col * s + dx) as i64;
                        let y = oy + (row * s + dy) as i64;
                        blend_pixel(frame, x, y, color, 1.0);
                    }
                }
            }
        }
    }
    bbox
}

/// Draws text on a filled background box with a `pad`-pixel margin; returns the box.
pub fn draw_label(
    frame: &mut RgbImage,
    text: &str,
    origin: [f64; 2],
    scale: usize,
    fg: Rgb,
    bg: Rgb,
) -> BBox {
    let pad = scale.max(1) as f64;
    let (w, h) = text_size(text, scale);
    let bbox = BBox::new(
        origin[0],
        origin[1],
        origin[0] + w as f64 + 2.0 * pad - 1.0,
        origin[1] + h as f64 + 2.0 * pad - 1.0,
    );
    fill_rect(frame, bbox, bg, 1.0);
    draw_text(frame, text, [origin[0] + pad, origin[1] + pad], scale, fg);
    bbox
}

/// How [`draw_hand`] draws.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandStyle {
    /// Width of the 2D skeleton's bones, pixels.
    pub bone_thickness: f64,
    /// Radius of the 2D keypoints, pixels.
    pub joint_radius: f64,
    /// Width of the projected 3D model's bones, pixels.
    pub model_thickness: f64,
    /// Radius of the projected 3D model's (hollow) joints, pixels.
    pub model_joint_radius: f64,
    /// Keypoints below this confidence are drawn dimmed (confidence 0: not drawn).
    pub min_confidence: f64,
    /// Opacity of dimmed keypoints and bones.
    pub dim_opacity: f64,
    /// Scale of the label font (0: no label).
    pub label_scale: usize,
}

impl Default for HandStyle {
    fn default() -> HandStyle {
        HandStyle {
            bone_thickness: 3.0,
            joint_radius: 3.5,
            model_thickness: 1.5,
            model_joint_radius: 3.0,
            min_confidence: 0.3,
            dim_opacity: 0.35,
            label_scale: 2,
        }
    }
}

impl HandStyle {
    /// Scaled for an image: lines and label grow with the image size (tuned for 640x480).
    pub fn for_image(width: usize, height: usize) -> HandStyle {
        let k = (width.max(height) as f64 / 640.0).clamp(0.5, 4.0);
        let d = HandStyle::default();
        HandStyle {
            bone_thickness: d.bone_thickness * k,
            joint_radius: d.joint_radius * k,
            model_thickness: d.model_thickness * k,
            model_joint_radius: d.model_joint_radius * k,
            label_scale: ((d.label_scale as f64 * k).round() as usize).max(1),
            ..d
        }
    }
}

/// The finger of a keypoint (`None` for the wrist).
fn finger_of(joint: usize) -> Option<usize> {
    (joint != WRIST).then(|| (joint - 1) / 4)
}

/// The label of a hand: `R` or `L`, then `#id` and the score if known, e.g. `R#3 0.97`.
pub fn hand_label(side: HandSide, id: Option<u64>, score: Option<f64>) -> String {
    let mut s = String::from(match side {
        HandSide::Left => "L",
        HandSide::Right => "R",
    });
    if let Some(id) = id {
        s.push_str(&format!("#{id}"));
    }
    if let Some(sc) = score.filter(|s| s.is_finite()) {
        s.push_str(&format!(" {sc:.2}"));
    }
    s
}

/// Projects 3D joints (mm, in the camera's reference frame, e.g. a fit's
/// `joints_3d_mm`) into the image for [`draw_hand`]; joints behind the camera
/// or non-finite become NaN, which drawing skips.
pub fn project_joints(
    camera: &Camera,
    joints_mm: &[[f64; 3]; NUM_JOINTS],
) -> [[f64; 2]; NUM_JOINTS] {
    joints_mm.map(|p| {
        if p.iter().any(|v| !v.is_finite()) {
            return [f64::NAN; 2];
        }
        camera
            .project(&Vector3::from(p))
            .map_or([f64::NAN; 2], |q| [q.x, q.y])
    })
}

/// Draws one hand:
///
/// - the 2D skeleton from `keypoints_2d` (`[u, v, confidence]`): bones in the
///   finger colours ([`FINGER_COLORS`]), filled keypoints, the wrist in the
///   side colour ([`side_color`]); keypoints below `style.min_confidence` and
///   their bones are dimmed, keypoints of confidence 0 (missing) are not drawn;
/// - if given, the fitted 3D model projected into the image (`projected_3d`,
///   pixels): thin bones and hollow joints in the side colour;
/// - a label such as `R#3 0.97` ([`hand_label`]) in the side colour above the hand.
///
/// Non-finite points are skipped.
pub fn draw_hand(
    frame: &mut RgbImage,
    keypoints_2d: &[[f64; 3]; NUM_JOINTS],
    projected_3d: Option<&[[f64; 2]; NUM_JOINTS]>,
    side: HandSide,
    id: Option<u64>,
    score: Option<f64>,
    style: &HandStyle,
) {
    let sc = side_color(side);
    if let Some(model) = projected_3d {
        let pen = Pen::new(sc, style.model_thickness);
        for &(a, b) in &BONES {
            draw_line(frame, model[a], model[b], &pen);
        }
        for p in model {
            draw_circle(frame, *p, style.model_joint_radius, &pen);
        }
    }
    let visible = |j: usize| {
        let p = keypoints_2d[j];
        p[2] > 0.0 && p.iter().all(|v| v.is_finite())
    };
    let opacity = |c: f64| {
        if c < style.min_confidence {
            style.dim_opacity
        } else {
            1.0
        }
    };
    for &(a, b) in &BONES {
        if !(visible(a) && visible(b)) {
            continue;
        }
        let color = finger_of(b).map_or(sc, |f| FINGER_COLORS[f]);
        let c = keypoints_2d[a][2].min(keypoints_2d[b][2]);
        let pen = Pen::new(color, style.bone_thickness).with_opacity(opacity(c));
        let (pa, pb) = (keypoints_2d[a], keypoints_2d[b]);
        draw_line(frame, [pa[0], pa[1]], [pb[0], pb[1]], &pen);
    }
    for (j, p) in keypoints_2d.iter().enumerate() {
        if !visible(j) {
            continue;
        }
        let color = finger_of(j).map_or(sc, |f| FINGER_COLORS[f]);
        let o = opacity(p[2]);
        let r = style.joint_radius;
        if j == WRIST {
            fill_circle(
                frame,
                [p[0], p[1]],
                r * 1.4,
                &Pen::new(sc, 1.0).with_opacity(o),
            );
        } else {
            fill_circle(
                frame,
                [p[0], p[1]],
                r,
                &Pen::new(color, 1.0).with_opacity(o),
            );
        }
    }
    if style.label_scale == 0 {
        return;
    }
    // Label above the top-left of the visible keypoints (or of the model).
    let pts: Vec<[f64; 2]> = (0..NUM_JOINTS)
        .filter(|&j| visible(j))
        .map(|j| [keypoints_2d[j][0], keypoints_2d[j][1]])
        .chain(projected_3d.into_iter().flatten().copied())
        .filter(|p| finite(*p))
        .collect();
    if pts.is_empty() {
        return;
    }
    let x = pts.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
    let y = pts.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
    let (_, th) = text_size("X", style.label_scale);
    let h = (th + 2 * style.label_scale) as f64;
    let top = (y - h - 4.0).max(0.0);
    let text = hand_label(side, id, score);
    draw_label(
        frame,
        &text,
        [x.max(0.0), top],
        style.label_scale,
        [0, 0, 0],
        sc,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The colour at `(x, y)`, `None` outside the image.
    trait Px {
        fn pixel(&self, x: usize, y: usize) -> Option<[u8; 3]>;
    }

    impl Px for RgbImage {
        fn pixel(&self, x: usize, y: usize) -> Option<[u8; 3]> {
            let (x, y) = (u32::try_from(x).ok()?, u32::try_from(y).ok()?);
            self.get_pixel_checked(x, y).map(|p| p.0)
        }
    }

    fn painted(f: &RgbImage) -> Vec<(usize, usize)> {
        let mut v = Vec::new();
        for y in 0..f.height() as usize {
            for x in 0..f.width() as usize {
                if f.pixel(x, y) != Some([0, 0, 0]) {
                    v.push((x, y));
                }
            }
        }
        v
    }

    #[test]
    fn horizontal_line_sets_exactly_its_pixels() {
        let mut f = RgbImage::new(12, 10);
        draw_line(&mut f, [2.0, 5.0], [8.0, 5.0], &Pen::new([255, 0, 0], 1.0));
        let expect: Vec<_> = (2..=8).map(|x| (x, 5)).collect();
        assert_eq!(painted(&f), expect);
        assert!(expect
            .iter()
            .all(|&(x, y)| f.pixel(x, y) == Some([255, 0, 0])));
    }

    #[test]
    fn thick_diagonal_line_covers_its_band() {
        let mut f = RgbImage::new(40, 40);
        let pen = Pen {
            antialias: false,
            ..Pen::new([0, 255, 0], 3.0)
        };
        draw_line(&mut f, [5.0, 5.0], [30.0, 30.0], &pen);
        for (x, y) in painted(&f) {
            // Distance to the segment at most half the width.
            let t = ((x as f64 - 5.0 + y as f64 - 5.0) / 50.0).clamp(0.0, 1.0);
            let (qx, qy) = (5.0 + 25.0 * t, 5.0 + 25.0 * t);
            let d = ((x as f64 - qx).powi(2) + (y as f64 - qy).powi(2)).sqrt();
            assert!(d <= 1.5 + 1e-9, "({x}, {y}) at {d}");
        }
        for i in 5..=30 {
            assert_eq!(f.pixel(i, i), Some([0, 255, 0]));
            assert_eq!(
                f.pixel(i + 1, i),
                Some([0, 255, 0]),
                "width 3 covers the neighbour"
            );
        }
        assert_eq!(f.pixel(10, 20), Some([0, 0, 0]));
    }

    #[test]
    fn antialiased_edges_are_partial() {
        let mut f = RgbImage::new(20, 20);
        draw_line(
            &mut f,
            [2.0, 10.0],
            [17.0, 10.5],
            &Pen::new([200, 200, 200], 1.0),
        );
        let v = f.pixel(10, 11).unwrap()[0];
        assert!(v > 0 && v < 200, "{v}");
    }

    #[test]
    fn shapes_outside_or_non_finite_are_clipped_not_panicking() {
        let mut f = RgbImage::new(16, 16);
        let pen = Pen::new([255, 255, 255], 4.0);
        draw_line(&mut f, [-100.0, -50.0], [-10.0, -3.0], &pen);
        draw_line(&mut f, [1e12, 3.0], [2e12, 9.0], &pen);
        draw_line(&mut f, [f64::NAN, 3.0], [5.0, 5.0], &pen);
        draw_line(&mut f, [f64::INFINITY, 3.0], [5.0, 5.0], &pen);
        fill_circle(&mut f, [f64::NAN, 1.0], 3.0, &pen);
        fill_circle(&mut f, [-20.0, -20.0], 3.0, &pen);
        draw_circle(&mut f, [100.0, 5.0], 3.0, &pen);
        draw_text(&mut f, "R#3", [f64::NAN, 0.0], 2, [255; 3]);
        draw_text(&mut f, "R#3", [-1e300, 1e300], 2, [255; 3]);
        draw_rect(&mut f, BBox::new(-10.0, -10.0, -5.0, -5.0), &pen);
        assert!(painted(&f).is_empty());
        // Partly inside: only the inside part is drawn.
        draw_line(
            &mut f,
            [-100.0, 8.0],
            [100.0, 8.0],
            &Pen::new([9, 9, 9], 1.0),
        );
        assert_eq!(painted(&f).len(), 16);
        fill_circle(&mut f, [15.0, 15.0], 5.0, &pen);
        assert_eq!(f.pixel(15, 15), Some([255, 255, 255]));
        // An empty image is fine too.
        let mut empty = RgbImage::new(0, 0);
        draw_line(&mut empty, [0.0, 0.0], [5.0, 5.0], &pen);
        draw_hand(
            &mut empty,
            &[[1.0, 1.0, 1.0]; NUM_JOINTS],
            None,
            HandSide::Left,
            Some(1),
            None,
            &HandStyle::default(),
        );
    }

    #[test]
    fn circles_and_rectangles() {
        let mut f = RgbImage::new(30, 30);
        let pen = Pen {
            antialias: false,
            ..Pen::new([10, 20, 30], 1.0)
        };
        fill_circle(&mut f, [15.0, 15.0], 4.0, &pen);
        assert_eq!(f.pixel(15, 11), Some([10, 20, 30]));
        assert_eq!(f.pixel(15, 10), Some([0, 0, 0]));
        assert_eq!(f.pixel(18, 18), Some([0, 0, 0]), "corner outside radius 4");
        let mut g = RgbImage::new(30, 30);
        draw_circle(&mut g, [15.0, 15.0], 6.0, &pen);
        assert_eq!(g.pixel(15, 15), Some([0, 0, 0]), "hollow");
        assert_eq!(g.pixel(21, 15), Some([10, 20, 30]));
        let mut h = RgbImage::new(30, 30);
        draw_rect(&mut h, BBox::new(3.0, 4.0, 20.0, 10.0), &pen);
        assert_eq!(h.pixel(3, 7), Some([10, 20, 30]));
        assert_eq!(h.pixel(12, 10), Some([10, 20, 30]));
        assert_eq!(h.pixel(12, 7), Some([0, 0, 0]));
        fill_rect(&mut h, BBox::new(0.0, 0.0, 1.0, 1.0), [1, 1, 1], 1.0);
        assert_eq!(
            painted(&h).iter().filter(|p| p.0 <= 1 && p.1 <= 1).count(),
            4
        );
    }

    #[test]
    fn font_draws_glyph_bitmaps() {
        let mut f = RgbImage::new(20, 10);
        let bbox = draw_text(&mut f, "1", [1.0, 1.0], 1, [255, 255, 255]);
        assert_eq!(bbox, BBox::new(1.0, 1.0, 6.0, 8.0));
        // "1": the stem is column 2 of the glyph for all 7 rows; the base is 3 wide.
        for row in 0..7 {
            assert_eq!(f.pixel(3, 1 + row), Some([255; 3]), "row {row}");
        }
        assert_eq!(f.pixel(2, 2), Some([255; 3]));
        assert_eq!(f.pixel(1, 2), Some([0; 3]));
        assert_eq!(painted(&f).len(), 7 + 1 + 2);
        let mut g = RgbImage::new(40, 20);
        draw_text(&mut g, "1", [0.0, 0.0], 2, [255; 3]);
        assert_eq!(painted(&g).len(), 4 * painted(&f).len());
        assert_eq!(text_size("R#3 0.97", 1), (47, 7));
        assert_eq!(
            hand_label(HandSide::Right, Some(3), Some(0.971)),
            "R#3 0.97"
        );
        assert_eq!(hand_label(HandSide::Left, None, None), "L");
    }

    fn hand_points() -> [[f64; 3]; NUM_JOINTS] {
        std::array::from_fn(|j| {
            if j == WRIST {
                [50.0, 90.0, 1.0]
            } else {
                let f = ((j - 1) / 4) as f64;
                let k = ((j - 1) % 4) as f64;
                [20.0 + 15.0 * f, 70.0 - 12.0 * k, 0.9]
            }
        })
    }

    #[test]
    fn projected_joints_land_where_the_camera_says() {
        let cam = Camera::pinhole(500.0, 500.0, 320.0, 240.0, 640, 480).unwrap();
        let mut j = [[10.0, -20.0, 500.0]; NUM_JOINTS];
        j[1] = [0.0, 0.0, -100.0]; // behind the camera
        j[2] = [f64::NAN, 0.0, 500.0];
        let p = project_joints(&cam, &j);
        assert!((p[0][0] - 330.0).abs() < 1e-9 && (p[0][1] - 220.0).abs() < 1e-9);
        assert!(p[1][0].is_nan() && p[2][0].is_nan());
        // Drawing the model with NaN joints does not panic and skips them.
        let mut f = RgbImage::new(640, 480);
        draw_hand(
            &mut f,
            &[[0.0; 3]; NUM_JOINTS],
            Some(&p),
            HandSide::Left,
            None,
            None,
            &HandStyle::default(),
        );
        assert_eq!(f.pixel(330, 220 - 3), Some(side_color(HandSide::Left)));
    }

    #[test]
    fn hand_skeleton_colours_dimming_and_model() {
        let style = HandStyle::default();
        let kp = hand_points();
        let mut f = RgbImage::new(120, 120);
        draw_hand(
            &mut f,
            &kp,
            None,
            HandSide::Right,
            Some(3),
            Some(0.97),
            &style,
        );
        // Index tip (joint 8) in the index colour, wrist in the right-hand colour.
        assert_eq!(f.pixel(35, 34), Some(FINGER_COLORS[1]));
        assert_eq!(f.pixel(50, 90), Some(side_color(HandSide::Right)));
        // A label was drawn above the hand, in the side colour.
        let label_px = (0..20).any(|y| f.pixel(22, y) == Some(side_color(HandSide::Right)));
        assert!(label_px);
        // Dimmed: low confidence blends with the background instead of covering it.
        let mut dim = kp;
        dim[8][2] = 0.1;
        let mut g = RgbImage::new(120, 120);
        draw_hand(&mut g, &dim, None, HandSide::Right, None, None, &style);
        let p = g.pixel(35, 34).unwrap();
        assert!(
            p != FINGER_COLORS[1] && p[0] > 0 && p[0] < FINGER_COLORS[1][0],
            "{p:?}"
        );
        // Missing (confidence 0) and NaN joints are not drawn.
        let mut miss = kp;
        miss[8] = [35.0, 34.0, 0.0];
        miss[12] = [f64::NAN, 1.0, 1.0];
        let mut h = RgbImage::new(120, 120);
        draw_hand(&mut h, &miss, None, HandSide::Left, None, None, &style);
        assert_eq!(h.pixel(35, 34), Some([0, 0, 0]));
        // The projected model: hollow joints in the side colour.
        let model: [[f64; 2]; NUM_JOINTS] = std::array::from_fn(|j| [kp[j][0] + 100.0, kp[j][1]]);
        let mut m = RgbImage::new(200, 120);
        let st = HandStyle {
            label_scale: 0,
            model_joint_radius: 6.0,
            ..style
        };
        draw_hand(&mut m, &kp, Some(&model), HandSide::Left, None, None, &st);
        let c = side_color(HandSide::Left);
        assert_eq!(m.pixel(135, 34 - 6), Some(c), "ring of the model index tip");
        assert_eq!(m.pixel(137, 34), Some([0, 0, 0]), "hollow inside the ring");
        assert_eq!(m.pixel(135, 40), Some(c), "model bone");
        assert_eq!(
            m.pixel(35, 34),
            Some(FINGER_COLORS[1]),
            "2D skeleton drawn as well"
        );
    }
}
