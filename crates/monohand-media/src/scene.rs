//! An overlay that shows the fitted hands in depth: the 3D model drawn as shaded
//! capsules (nearer parts over farther ones, lit from the upper left, farther parts
//! darker), a small top view of the scene (the x-z plane, cameras at the bottom, with a
//! millimetre scale) so that absolute distance reads at a glance, and labels with each
//! hand's distance from the camera. Each part is a layer ([`Layers`]) that can be turned
//! off; the 2D keypoints and the flat projected model of [`crate::overlay::draw_hand`]
//! are layers too.
//!
//! [`SceneRenderer`] keeps its depth and colour buffers between frames (they grow to the
//! largest frame drawn), so drawing allocates nothing per frame after the first.
//!
//! ```
//! use monohand_core::camera::Camera;
//! use monohand_media::scene::{Layers, SceneRenderer};
//! use monohand_media::video::RgbImage;
//! let camera = Camera::pinhole(500.0, 500.0, 320.0, 240.0, 640, 480)?;
//! let mut frame = RgbImage::new(640, 480);
//! let mut renderer = SceneRenderer::default();
//! renderer.draw(&mut frame, &[], &[camera], &Layers::default());
//! // No hands: only the top-view inset (bottom right) was drawn.
//! assert_eq!(frame.get_pixel(10, 10).0, [0, 0, 0]);
//! assert_ne!(frame.get_pixel(600, 450).0, [0, 0, 0]);
//! # Ok::<(), monohand_core::CoreError>(())
//! ```

use crate::overlay::{
    draw_hand, draw_label, draw_line, draw_rect, draw_text, fill_circle, fill_rect, hand_label,
    project_joints, text_size, HandStyle, Pen,
};
use crate::video::RgbImage;
use monohand_core::bbox::BBox;
use monohand_core::camera::Camera;
use monohand_core::hand_model::{BONES, NUM_JOINTS, WRIST};
use monohand_io::jsonl::{FrameRecord, HandRecord};
use monohand_io::palette::{side_color, Rgb, FINGER_COLORS};
use nalgebra::{Point2, Vector3};

/// One part of the overlay, for [`Layers`] and the live window's keys.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layer {
    /// The network's 2D keypoints: the skeleton in finger colours.
    Keypoints,
    /// The fitted 3D model projected as thin lines with hollow joints.
    Model,
    /// The fitted 3D model as shaded capsules, nearer over farther.
    Bones,
    /// The inset seen from above (x-z plane) with a millimetre scale.
    Top,
    /// Each hand's side, id, score and distance from the camera.
    Labels,
}

impl Layer {
    /// Every layer, in drawing order.
    pub const ALL: [Layer; 5] = [
        Layer::Keypoints,
        Layer::Model,
        Layer::Bones,
        Layer::Top,
        Layer::Labels,
    ];

    /// The layer's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Layer::Keypoints => "keypoints",
            Layer::Model => "model",
            Layer::Bones => "bones",
            Layer::Top => "top",
            Layer::Labels => "labels",
        }
    }
}

/// A layer name that is not one of [`Layer::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown overlay layer `{0}` (layers: keypoints, model, bones, top, labels)")]
pub struct UnknownLayer(pub String);

impl std::str::FromStr for Layer {
    type Err = UnknownLayer;

    fn from_str(s: &str) -> Result<Layer, UnknownLayer> {
        Layer::ALL
            .into_iter()
            .find(|l| l.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownLayer(s.to_string()))
    }
}

/// Which parts of the overlay are drawn. The default (bones, top view, labels) stays
/// readable on a busy image; the 2D keypoints and the flat model are for checking a fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layers {
    /// [`Layer::Keypoints`].
    pub keypoints: bool,
    /// [`Layer::Model`].
    pub model: bool,
    /// [`Layer::Bones`].
    pub bones: bool,
    /// [`Layer::Top`].
    pub top: bool,
    /// [`Layer::Labels`].
    pub labels: bool,
}

impl Default for Layers {
    fn default() -> Layers {
        Layers {
            keypoints: false,
            model: false,
            bones: true,
            top: true,
            labels: true,
        }
    }
}

impl Layers {
    /// No layer at all.
    pub const NONE: Layers = Layers {
        keypoints: false,
        model: false,
        bones: false,
        top: false,
        labels: false,
    };

    /// Exactly these layers.
    pub fn only(layers: &[Layer]) -> Layers {
        let mut l = Layers::NONE;
        for &x in layers {
            *l.flag(x) = true;
        }
        l
    }

    /// Whether a layer is drawn.
    pub fn has(&self, layer: Layer) -> bool {
        match layer {
            Layer::Keypoints => self.keypoints,
            Layer::Model => self.model,
            Layer::Bones => self.bones,
            Layer::Top => self.top,
            Layer::Labels => self.labels,
        }
    }

    /// Turns a layer on or off.
    pub fn toggle(&mut self, layer: Layer) {
        let f = self.flag(layer);
        *f = !*f;
    }

    fn flag(&mut self, layer: Layer) -> &mut bool {
        match layer {
            Layer::Keypoints => &mut self.keypoints,
            Layer::Model => &mut self.model,
            Layer::Bones => &mut self.bones,
            Layer::Top => &mut self.top,
            Layer::Labels => &mut self.labels,
        }
    }
}

/// Radius of the model's capsule at a joint, mm: 10 at the wrist and the thumb's base,
/// 9 at a finger's base, tapering to 6 at its tip.
pub fn joint_radius_mm(joint: usize) -> f64 {
    if joint == WRIST {
        return 10.0;
    }
    let k = (joint - 1) % 4;
    if joint == 1 {
        10.0
    } else {
        9.0 - k as f64
    }
}

/// Distance of a hand from the camera centre, mm: the norm of the palm's centre (the
/// mean of the wrist and the five finger bases), in the frame of `joints_mm`.
pub fn hand_distance_mm(joints_mm: &[[f64; 3]; NUM_JOINTS]) -> f64 {
    let palm = [0usize, 1, 5, 9, 13, 17];
    let mut c = [0.0; 3];
    for &j in &palm {
        for (ck, v) in c.iter_mut().zip(joints_mm[j]) {
            *ck += v / palm.len() as f64;
        }
    }
    (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
}

/// The label of a hand with its distance: `R#3 0.97 42CM`.
pub fn hand_label_with_distance(hand: &HandRecord) -> String {
    let mut s = hand_label(hand.side, hand.id, hand.score);
    if let Some(j) = &hand.joints_3d_mm {
        let d = hand_distance_mm(j);
        if d.is_finite() {
            s.push_str(&format!(" {:.0}CM", d / 10.0));
        }
    }
    s
}

/// Direction towards the light in the camera frame (upper left, in front): x right,
/// y down, z forward.
const LIGHT: [f64; 3] = [-0.45, -0.65, -0.61];
/// Ambient, diffuse and specular shares of the shading.
const AMBIENT: f64 = 0.32;
const DIFFUSE: f64 = 0.68;
const SPECULAR: f64 = 0.35;
/// Depth over which a hand's farthest parts darken, mm, and by how much.
const DEPTH_CUE_MM: f64 = 120.0;
const DEPTH_CUE: f64 = 0.35;

/// A sphere of the model seen by the camera: centre in pixels, radius in pixels, depth and
/// radius in mm.
#[derive(Debug, Clone, Copy)]
struct Ball {
    c: [f64; 2],
    r_px: f64,
    z: f64,
    r_mm: f64,
}

/// Draws [`Layers`] of hands on frames; owns the depth buffer (reused across frames).
#[derive(Debug, Default)]
pub struct SceneRenderer {
    width: usize,
    /// Nearest depth drawn at each pixel, mm (`INFINITY`: nothing).
    depth: Vec<f32>,
    /// Colour drawn at each pixel, premultiplied by its coverage, `[0, 255]`.
    color: Vec<[f32; 3]>,
    /// Coverage of each pixel by the model, `[0, 1]`.
    cover: Vec<f32>,
    /// The pixels touched this frame `[x0, y0, x1, y1]` (inclusive), if any.
    dirty: Option<[usize; 4]>,
    /// Where the frame's camera came from, shown once with the labels.
    camera_source: Option<String>,
}

impl SceneRenderer {
    /// Says where the camera of the frames to come came from (a record's camera `source`,
    /// such as `exif+sensor-db`): the [`Layer::Labels`] layer shows it once, at the
    /// frame's bottom left (`CAMERA EXIF+SENSOR-DB`), since every distance drawn rests on
    /// it. `None`: not shown.
    pub fn set_camera_source(&mut self, source: Option<&str>) {
        self.camera_source = source.map(|s| format!("CAMERA {}", s.to_uppercase()));
    }

    /// Draws a frame's record on `frame` ([`SceneRenderer::draw`]), labelled with the source
    /// of the camera its record names.
    pub fn draw_record(
        &mut self,
        frame: &mut RgbImage,
        record: &FrameRecord,
        cameras: &[Camera],
        layers: &Layers,
    ) {
        self.set_camera_source(record.cameras.first().map(|c| c.source.name()));
        self.draw(frame, &record.hands, cameras, layers);
    }

    /// Draws `hands` on `frame` with the chosen layers. `cameras[0]` is the camera of
    /// `frame` (the reference frame of the hands' `joints_3d_mm`); the others, if any, are
    /// the rest of a rig, drawn in the top view. Without a camera, a generic one for the
    /// frame's size is used. Hands without a fit get only their 2D layers. Never fails:
    /// non-finite values are skipped.
    pub fn draw(
        &mut self,
        frame: &mut RgbImage,
        hands: &[HandRecord],
        cameras: &[Camera],
        layers: &Layers,
    ) {
        let (w, h) = (frame.width() as usize, frame.height() as usize);
        if w == 0 || h == 0 {
            return;
        }
        let generic;
        let cameras = if cameras.is_empty() {
            match Camera::generic(w as u32, h as u32) {
                Ok(c) => {
                    generic = [c];
                    &generic[..]
                }
                Err(_) => return,
            }
        } else {
            cameras
        };
        let camera = &cameras[0];
        let style = HandStyle::for_image(w, h);
        if layers.bones {
            self.begin(w, h);
            for hand in hands {
                if let Some(joints) = &hand.joints_3d_mm {
                    self.hand_bones(camera, joints, hand);
                }
            }
            self.composite(frame);
        }
        for hand in hands {
            let projected = match (&hand.joints_3d_mm, layers.model) {
                (Some(j), true) => Some(project_joints(camera, j)),
                _ => None,
            };
            let kp = if layers.keypoints {
                hand.keypoints_2d
            } else {
                [[0.0; 3]; NUM_JOINTS]
            };
            if layers.keypoints || projected.is_some() {
                let st = HandStyle {
                    label_scale: 0,
                    ..style
                };
                draw_hand(frame, &kp, projected.as_ref(), hand.side, None, None, &st);
            }
        }
        if layers.labels {
            let mut placed = Vec::with_capacity(hands.len());
            for hand in hands {
                draw_hand_label(frame, camera, hand, style.label_scale, &mut placed);
            }
            if let Some(text) = &self.camera_source {
                let scale = style.label_scale.max(1);
                let (_, th) = text_size(text, scale);
                let margin = (w.min(h) as f64 * 0.02).round().max(4.0);
                let y = (h as f64 - margin - (th + 2 * scale) as f64).max(0.0);
                draw_label(frame, text, [margin, y], scale, [0, 0, 0], [220, 220, 220]);
            }
        }
        if layers.top {
            draw_top_view(frame, hands, cameras);
        }
    }

    /// Sizes the buffers for a `w x h` frame; they are clean (only touched pixels are
    /// reset after each frame).
    fn begin(&mut self, w: usize, h: usize) {
        if self.width != w || self.depth.len() != w * h {
            self.width = w;
            self.depth = vec![f32::INFINITY; w * h];
            self.color = vec![[0.0; 3]; w * h];
            self.cover = vec![0.0; w * h];
        }
        self.dirty = None;
    }

    /// Renders the capsules of one hand into the buffers.
    fn hand_bones(&mut self, camera: &Camera, joints: &[[f64; 3]; NUM_JOINTS], hand: &HandRecord) {
        let k = &camera.intrinsics;
        let f = 0.5 * (k.fx + k.fy);
        let balls: [Option<Ball>; NUM_JOINTS] = std::array::from_fn(|j| {
            let p = Vector3::from(joints[j]);
            if p.iter().any(|v| !v.is_finite()) {
                return None;
            }
            let z = camera.extrinsics.transform(&p).z;
            let q = camera.project(&p)?;
            let r_mm = joint_radius_mm(j);
            let r_px = f * r_mm / z;
            (r_px.is_finite() && r_px > 0.0 && r_px < 1e4).then_some(Ball {
                c: [q.x, q.y],
                r_px,
                z,
                r_mm,
            })
        });
        let near = balls
            .iter()
            .flatten()
            .map(|b| b.z - b.r_mm)
            .fold(f64::INFINITY, f64::min);
        let side = side_color(hand.side);
        for &(a, b) in &BONES {
            let (Some(ba), Some(bb)) = (balls[a], balls[b]) else {
                continue;
            };
            let color = if a == WRIST {
                side
            } else {
                FINGER_COLORS[(b - 1) / 4]
            };
            self.capsule(ba, bb, color, near);
        }
    }

    /// Renders a capsule (a sphere swept from `a` to `b`, its radius changing linearly).
    fn capsule(&mut self, a: Ball, b: Ball, color: Rgb, near: f64) {
        let (w, h) = (self.width, self.depth.len() / self.width.max(1));
        let m = a.r_px.max(b.r_px) + 1.0;
        let x0 = (a.c[0].min(b.c[0]) - m).floor().max(0.0);
        let y0 = (a.c[1].min(b.c[1]) - m).floor().max(0.0);
        let x1 = (a.c[0].max(b.c[0]) + m).ceil().min(w as f64 - 1.0);
        let y1 = (a.c[1].max(b.c[1]) + m).ceil().min(h as f64 - 1.0);
        if !(x0 <= x1 && y0 <= y1) {
            return;
        }
        let (x0, y0, x1, y1) = (x0 as usize, y0 as usize, x1 as usize, y1 as usize);
        self.dirty = Some(match self.dirty {
            None => [x0, y0, x1, y1],
            Some(d) => [d[0].min(x0), d[1].min(y0), d[2].max(x1), d[3].max(y1)],
        });
        let l = Vector3::from(LIGHT).normalize();
        let half = (l + Vector3::new(0.0, 0.0, -1.0)).normalize();
        let (dx, dy) = (b.c[0] - a.c[0], b.c[1] - a.c[1]);
        let len2 = dx * dx + dy * dy;
        let base = color.map(f64::from);
        let len = len2.sqrt();
        for y in y0..=y1 {
            let py = y as f64;
            let row = y * w;
            // The capsule lies within `m` of the segment's line: on this row, only the
            // pixels of that strip can be covered (most of a diagonal bone's box is not).
            let (sx0, sx1) = if dy.abs() > 1e-9 {
                let c = a.c[0] + (py - a.c[1]) * dx / dy;
                let half = m * len / dy.abs();
                (
                    ((c - half).floor().max(x0 as f64)) as usize,
                    ((c + half).ceil().min(x1 as f64)) as usize,
                )
            } else {
                (x0, x1)
            };
            if sx0 > sx1 {
                continue;
            }
            for x in sx0..=sx1 {
                let px = x as f64;
                let t = if len2 > 1e-12 {
                    (((px - a.c[0]) * dx + (py - a.c[1]) * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (ox, oy) = (px - a.c[0] - t * dx, py - a.c[1] - t * dy);
                let d = (ox * ox + oy * oy).sqrt();
                let r = a.r_px + t * (b.r_px - a.r_px);
                let cov = (r - d + 0.5).clamp(0.0, 1.0);
                if cov <= 0.0 {
                    continue;
                }
                let s = (d / r).min(1.0);
                let hz = (1.0 - s * s).sqrt();
                let depth = a.z + t * (b.z - a.z) - (a.r_mm + t * (b.r_mm - a.r_mm)) * hz;
                let i = row + x;
                if depth as f32 >= self.depth[i] && self.cover[i] >= 1.0 {
                    // Hidden behind a surface that covers the pixel: nothing to add.
                    continue;
                }
                let n = Vector3::new(ox / r, oy / r, -hz);
                let diffuse = n.dot(&l).max(0.0);
                let spec = n.dot(&half).max(0.0).powi(24);
                let cue = 1.0 - DEPTH_CUE * ((depth - near) / DEPTH_CUE_MM).clamp(0.0, 1.0);
                let shade = (AMBIENT + DIFFUSE * diffuse) * cue;
                let frag = base.map(|c| (c * shade + 255.0 * SPECULAR * spec).min(255.0) as f32);
                let (cov, depth) = (cov as f32, depth as f32);
                let (col, cv) = (&mut self.color[i], &mut self.cover[i]);
                if depth < self.depth[i] {
                    // In front: over what is there.
                    for (c, f) in col.iter_mut().zip(frag) {
                        *c = f * cov + *c * (1.0 - cov);
                    }
                    *cv = cov + *cv * (1.0 - cov);
                    if cov >= 0.5 {
                        self.depth[i] = depth;
                    }
                } else {
                    // Behind: only where the nearer surface leaves the pixel uncovered.
                    let k = cov * (1.0 - *cv);
                    for (c, f) in col.iter_mut().zip(frag) {
                        *c += f * k;
                    }
                    *cv += k;
                }
            }
        }
    }

    /// Blends the rendered model over the frame and resets the touched pixels.
    fn composite(&mut self, frame: &mut RgbImage) {
        let Some([x0, y0, x1, y1]) = self.dirty.take() else {
            return;
        };
        let w = self.width;
        if frame.width() as usize != w {
            return;
        }
        let data: &mut [u8] = frame;
        for y in y0..=y1 {
            let span = y * w + x0..y * w + x1 + 1;
            let (Some(cover), Some(color), Some(px)) = (
                self.cover.get(span.clone()),
                self.color.get(span.clone()),
                data.get_mut(3 * span.start..3 * span.end),
            ) else {
                return;
            };
            for ((&cv, c), p) in cover.iter().zip(color).zip(px.chunks_exact_mut(3)) {
                if cv > 0.0 {
                    for (p, &ck) in p.iter_mut().zip(c) {
                        *p = (ck + *p as f32 * (1.0 - cv)).round().clamp(0.0, 255.0) as u8;
                    }
                }
            }
            // Reset the touched buffers for the next frame.
            self.depth[span.clone()].fill(f32::INFINITY);
            self.color[span.clone()].fill([0.0; 3]);
            self.cover[span].fill(0.0);
        }
    }
}

/// Draws a hand's label (`R#3 0.97 42CM`, black on the side colour) above its model, or
/// above its keypoints without a fit, clear of the labels in `placed` (to which its box is
/// added): two hands side by side would otherwise print one label over the other.
fn draw_hand_label(
    frame: &mut RgbImage,
    camera: &Camera,
    hand: &HandRecord,
    scale: usize,
    placed: &mut Vec<BBox>,
) {
    if scale == 0 {
        return;
    }
    let pts: Vec<[f64; 2]> = match &hand.joints_3d_mm {
        Some(j) => project_joints(camera, j).to_vec(),
        None => hand
            .keypoints_2d
            .iter()
            .filter(|p| p[2] > 0.0)
            .map(|p| [p[0], p[1]])
            .collect(),
    };
    let pts: Vec<[f64; 2]> = pts
        .into_iter()
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .collect();
    if pts.is_empty() {
        return;
    }
    let x = pts.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
    let y = pts.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
    let text = hand_label_with_distance(hand);
    let (tw, th) = text_size(&text, scale);
    let pad = scale.max(1) as f64;
    let size = [tw as f64 + 2.0 * pad, th as f64 + 2.0 * pad];
    let top = (y - (th + 2 * scale) as f64 - 12.0).max(0.0);
    let origin = clear_of(placed, [x.max(0.0), top], size);
    placed.push(draw_label(
        frame,
        &text,
        origin,
        scale,
        [0, 0, 0],
        side_color(hand.side),
    ));
}

/// Where a `size` box wanted at `at` goes so that it overlaps none of `placed`: at `at` if
/// it is free, else moved up past each box it meets, or down below it once up is off the
/// frame (at most one step per placed box, so it always ends).
fn clear_of(placed: &[BBox], at: [f64; 2], size: [f64; 2]) -> [f64; 2] {
    let gap = 2.0;
    let boxed = |o: [f64; 2]| BBox::new(o[0], o[1], o[0] + size[0] - 1.0, o[1] + size[1] - 1.0);
    let mut o = at;
    for _ in 0..=placed.len() {
        let Some(hit) = placed.iter().find(|b| b.intersection_area(&boxed(o)) > 0.0) else {
            return o;
        };
        let up = hit.y_min - gap - size[1];
        o[1] = if up >= 0.0 { up } else { hit.y_max + 1.0 + gap };
    }
    o
}

/// A round number at least `v`: 1, 1.5, 2, 2.5, 3, 5 or 7.5 times a power of ten.
fn nice_ceil(v: f64) -> f64 {
    let p = 10f64.powf(v.max(1e-9).log10().floor());
    [1.0, 1.5, 2.0, 2.5, 3.0, 5.0, 7.5, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|&c| c >= v)
        .unwrap_or(10.0 * p)
}

/// The part of segment `a`-`b` inside the box (Liang-Barsky), if any.
fn clip_segment(a: [f64; 2], b: [f64; 2], r: BBox) -> Option<([f64; 2], [f64; 2])> {
    let r = r.to_array();
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a[0] - r[0]),
        (dx, r[2] - a[0]),
        (-dy, a[1] - r[1]),
        (dy, r[3] - a[1]),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t0 <= t1 && t0.is_finite() && t1.is_finite()).then(|| {
        (
            [a[0] + t0 * dx, a[1] + t0 * dy],
            [a[0] + t1 * dx, a[1] + t1 * dy],
        )
    })
}

/// Where the top view sits in a frame and how it maps millimetres to its pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TopView {
    /// The inset's box in the frame, pixels.
    pub rect: BBox,
    /// Depth (z, mm) at the top edge of the plot; the bottom edge is at z = `z_min`.
    pub z_max: f64,
    /// Depth at the bottom edge of the plot, mm (0, or behind the rear camera of a rig).
    pub z_min: f64,
    /// Spacing of the scale's lines, mm.
    pub step: f64,
    /// Pixels per millimetre.
    pub scale: f64,
    /// The x (mm) at the plot's centre line.
    pub x_centre: f64,
}

/// Margin inside the inset around the plot, pixels, before scaling with the image.
const INSET_PAD: f64 = 6.0;

impl TopView {
    /// The top view for a frame of `w x h` showing `hands` and `cameras`: a square in the
    /// bottom-right corner, 30% of the frame's smaller side, its depth range rounded up
    /// to take in every hand and camera (at least 0-500 mm).
    pub fn layout(w: usize, h: usize, hands: &[HandRecord], cameras: &[Camera]) -> TopView {
        let side = (0.3 * w.min(h) as f64).round().max(60.0);
        let margin = (w.min(h) as f64 * 0.02).round().max(4.0);
        let rect = BBox::new(
            w as f64 - margin - side,
            h as f64 - margin - side,
            w as f64 - margin - 1.0,
            h as f64 - margin - 1.0,
        );
        let mut far: f64 = 500.0;
        let mut z_min: f64 = 0.0;
        let mut xs = Vec::new();
        for c in cameras {
            let p = c.centre();
            z_min = z_min.min(p.z);
            xs.push(p.x);
        }
        for j in hands.iter().filter_map(|h| h.joints_3d_mm.as_ref()) {
            for p in j.iter().filter(|p| p.iter().all(|v| v.is_finite())) {
                far = far.max(p[2] * 1.15);
            }
        }
        let z_max = nice_ceil(far);
        let x_centre = if xs.is_empty() {
            0.0
        } else {
            0.5 * (xs.iter().copied().fold(f64::INFINITY, f64::min)
                + xs.iter().copied().fold(f64::NEG_INFINITY, f64::max))
        };
        let k = (w.max(h) as f64 / 640.0).clamp(0.5, 4.0);
        let text_h = (GLYPH_ROWS * k.round().max(1.0)) + 2.0;
        let plot_h = side - 2.0 * INSET_PAD * k - text_h;
        let scale = plot_h / (z_max - z_min);
        let step = nice_ceil((z_max - z_min) / 4.0);
        TopView {
            rect,
            z_max,
            z_min,
            step,
            scale,
            x_centre,
        }
    }

    /// The inset pixel of a point (mm, reference frame): x to the right, z upwards.
    pub fn to_pixel(&self, x_mm: f64, z_mm: f64) -> [f64; 2] {
        let [x0, _, x1, y1] = self.rect.to_array();
        let bottom = y1 - INSET_PAD;
        [
            0.5 * (x0 + x1) + (x_mm - self.x_centre) * self.scale,
            bottom - (z_mm - self.z_min) * self.scale,
        ]
    }
}

/// Rows of the font.
const GLYPH_ROWS: f64 = crate::overlay::GLYPH_H as f64;

/// Draws the top-view inset: a dark box, depth lines every `step` mm labelled in mm, each
/// camera as a dot with its field of view, and each fitted hand's bones seen from above.
pub fn draw_top_view(frame: &mut RgbImage, hands: &[HandRecord], cameras: &[Camera]) {
    let (w, h) = (frame.width() as usize, frame.height() as usize);
    let tv = TopView::layout(w, h, hands, cameras);
    let r = tv.rect.to_array();
    let k = (w.max(h) as f64 / 640.0).clamp(0.5, 4.0);
    let ts = (k.round() as usize).max(1);
    fill_rect(frame, tv.rect, [16, 16, 20], 0.72);
    draw_rect(frame, tv.rect, &Pen::new([150, 150, 150], 1.0));
    let inner = BBox::new(r[0] + 1.0, r[1] + 1.0, r[2] - 1.0, r[3] - 1.0);
    let grid = Pen::new([90, 90, 90], 1.0);
    let mut z = (tv.z_min / tv.step).ceil() * tv.step;
    while z <= tv.z_max + 1e-9 {
        let y = tv.to_pixel(0.0, z)[1].round();
        draw_line(frame, [r[0] + 2.0, y], [r[2] - 2.0, y], &grid);
        if z > 0.0 {
            draw_text(
                frame,
                &format!("{z:.0}"),
                [r[0] + 3.0, y + 2.0],
                ts,
                [170, 170, 170],
            );
        }
        z += tv.step;
    }
    draw_text(
        frame,
        "TOP, MM",
        [r[0] + 3.0, r[1] + 3.0],
        ts,
        [200, 200, 200],
    );
    // Cameras: a dot and the edges of the field of view.
    for cam in cameras {
        let c = cam.centre();
        let k = &cam.intrinsics;
        let reach = 2.0 * (tv.z_max - tv.z_min);
        for u in [0.0, k.width as f64 - 1.0] {
            let Some(ray) = cam.ray(Point2::new(u, k.cy)) else {
                continue;
            };
            let d = cam.extrinsics.rotation.inverse() * ray;
            let e = c + d * reach;
            if let Some((p, q)) = clip_segment(tv.to_pixel(c.x, c.z), tv.to_pixel(e.x, e.z), inner)
            {
                draw_line(frame, p, q, &Pen::new([120, 120, 160], 1.0));
            }
        }
        let p = tv.to_pixel(c.x, c.z);
        fill_circle(
            frame,
            p,
            2.5 * k_scale(w, h),
            &Pen::new([230, 230, 230], 1.0),
        );
    }
    // Hands from above.
    for hand in hands {
        let Some(j) = &hand.joints_3d_mm else {
            continue;
        };
        let pen_w = 1.5 * k_scale(w, h);
        for &(a, b) in &BONES {
            let color = if a == WRIST {
                side_color(hand.side)
            } else {
                FINGER_COLORS[(b - 1) / 4]
            };
            let pa = tv.to_pixel(j[a][0], j[a][2]);
            let pb = tv.to_pixel(j[b][0], j[b][2]);
            if let Some((p, q)) = clip_segment(pa, pb, inner) {
                draw_line(frame, p, q, &Pen::new(color, pen_w));
            }
        }
        let p = tv.to_pixel(j[WRIST][0], j[WRIST][2]);
        if inner.contains(p) {
            fill_circle(
                frame,
                p,
                2.0 * k_scale(w, h),
                &Pen::new(side_color(hand.side), 1.0),
            );
        }
    }
}

/// Line widths grow with the image (1 at 640x480).
fn k_scale(w: usize, h: usize) -> f64 {
    (w.max(h) as f64 / 640.0).clamp(0.5, 4.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use monohand_core::hand_model::HandSide;

    fn cam() -> Camera {
        Camera::pinhole(500.0, 500.0, 320.0, 240.0, 640, 480).unwrap()
    }

    fn record(side: HandSide, joints: [[f64; 3]; NUM_JOINTS]) -> HandRecord {
        HandRecord {
            joints_3d_mm: Some(joints),
            ..HandRecord::from_keypoints(side, &Default::default())
        }
    }

    /// A flat hand in the image plane at depth `z`, wrist at `(x, y)`, fingers up.
    fn flat_hand(x: f64, y: f64, z: f64) -> [[f64; 3]; NUM_JOINTS] {
        std::array::from_fn(|j| {
            if j == WRIST {
                [x, y, z]
            } else {
                let f = ((j - 1) / 4) as f64;
                let k = ((j - 1) % 4 + 1) as f64;
                [x + 20.0 * (f - 2.0), y - 40.0 - 20.0 * k, z]
            }
        })
    }

    fn bones_only() -> Layers {
        Layers::only(&[Layer::Bones])
    }

    #[test]
    fn layer_names_parse_and_toggle() {
        assert_eq!("Top".parse::<Layer>(), Ok(Layer::Top));
        assert!("depth".parse::<Layer>().is_err());
        let mut l = Layers::default();
        assert!(l.bones && l.top && l.labels && !l.keypoints && !l.model);
        l.toggle(Layer::Bones);
        assert!(!l.has(Layer::Bones));
        assert!(Layers::only(&Layer::ALL).has(Layer::Keypoints));
    }

    #[test]
    fn nothing_drawn_without_layers() {
        let mut f = RgbImage::new(640, 480);
        let hands = [record(HandSide::Left, flat_hand(0.0, 60.0, 400.0))];
        SceneRenderer::default().draw(&mut f, &hands, &[cam()], &Layers::NONE);
        assert!(f.pixels().all(|p| p.0 == [0, 0, 0]));
    }

    /// A hand of one palm bone, from the wrist at `a` to the base of finger `finger`
    /// at `b` (the other joints are unknown: NaN, not drawn).
    fn one_bone(a: [f64; 3], b: [f64; 3], finger: usize) -> [[f64; 3]; NUM_JOINTS] {
        let mut j = [[f64::NAN; 3]; NUM_JOINTS];
        j[WRIST] = a;
        j[1 + 4 * finger] = b;
        j
    }

    #[test]
    fn nearer_hand_is_drawn_over_the_farther_one_in_either_order() {
        // A horizontal bone of a right hand (orange) at 300 mm crosses a vertical bone of
        // a left hand (cyan) at 600 mm in front of the image centre.
        let near = record(
            HandSide::Right,
            one_bone([-60.0, 0.0, 300.0], [60.0, 0.0, 300.0], 1),
        );
        let far = record(
            HandSide::Left,
            one_bone([0.0, -120.0, 600.0], [0.0, 120.0, 600.0], 2),
        );
        let c = cam();
        let mut r = SceneRenderer::default();
        for hands in [[near.clone(), far.clone()], [far.clone(), near.clone()]] {
            let mut f = RgbImage::new(640, 480);
            r.draw(&mut f, &hands, &[c], &bones_only());
            let p = f.get_pixel(320, 240).0;
            assert!(p[0] > p[2] + 60, "near orange over far cyan: {p:?}");
            // The far bone is drawn where the near one does not hide it.
            let q = f.get_pixel(320, 300).0;
            assert!(q[2] > q[0] + 60, "far cyan bone: {q:?}");
        }
    }

    #[test]
    fn capsules_are_lit_from_the_upper_left_and_darker_when_farther() {
        let c = cam();
        let mut f = RgbImage::new(640, 480);
        // One horizontal bone across the image centre (palm bone: the side colour).
        let j = one_bone([0.0, 0.0, 400.0], [80.0, 0.0, 400.0], 0);
        let hands = [record(HandSide::Right, j)];
        SceneRenderer::default().draw(&mut f, &hands, &[c], &bones_only());
        // Bone radius at the wrist: 10 mm at 400 mm -> 12.5 px. Above the axis (towards
        // the light) is brighter than below it.
        let up = f.get_pixel(370, 240 - 8).0;
        let down = f.get_pixel(370, 240 + 8).0;
        let lum = |p: [u8; 3]| p.iter().map(|&v| v as u32).sum::<u32>();
        assert!(lum(up) > lum(down) + 60, "{up:?} vs {down:?}");
        // Outside the radius nothing is drawn.
        assert_eq!(f.get_pixel(370, 240 + 16).0, [0, 0, 0]);
        // The same bone tilted away (far end 150 mm deeper) is darker at its far end.
        let mut g = RgbImage::new(640, 480);
        let mut t = j;
        t[1] = [80.0, 0.0, 550.0];
        SceneRenderer::default().draw(&mut g, &[record(HandSide::Right, t)], &[c], &bones_only());
        let end = c.project(&Vector3::new(70.0, 0.0, 540.0)).unwrap();
        let start = c.project(&Vector3::new(10.0, 0.0, 410.0)).unwrap();
        let pe = g.get_pixel(end.x.round() as u32, end.y.round() as u32).0;
        let ps = g
            .get_pixel(start.x.round() as u32, start.y.round() as u32)
            .0;
        assert!(lum(ps) > lum(pe) + 30, "{ps:?} vs {pe:?}");
    }

    #[test]
    fn top_view_places_hands_at_their_depth_on_the_mm_scale() {
        let c = cam();
        let near = record(HandSide::Right, flat_hand(-100.0, 60.0, 300.0));
        let far = record(HandSide::Left, flat_hand(100.0, 60.0, 800.0));
        let hands = [near, far];
        let tv = TopView::layout(640, 480, &hands, &[c]);
        assert_eq!(tv.z_max, 1000.0, "800 mm * 1.15 rounds up to 1000");
        assert_eq!(tv.step, 250.0);
        let mut f = RgbImage::new(640, 480);
        draw_top_view(&mut f, &hands, &[c]);
        for (h, z) in [(&hands[0], 300.0), (&hands[1], 800.0)] {
            let x = h.joints_3d_mm.unwrap()[WRIST][0];
            let p = tv.to_pixel(x, z);
            assert_eq!(
                f.get_pixel(p[0].round() as u32, p[1].round() as u32).0,
                side_color(h.side),
                "wrist at z = {z}"
            );
        }
        // The camera is at the bottom centre of the plot, drawn light grey.
        let cp = tv.to_pixel(0.0, 0.0);
        assert_eq!(f.get_pixel(cp[0] as u32, cp[1] as u32).0, [230, 230, 230]);
        assert!(cp[1] > tv.rect.y_max - 10.0);
        // The inset covers the bottom-right corner, not the top-left.
        assert!(tv.rect.x_min > 400.0 && tv.rect.y_min > 300.0);
        assert_eq!(f.get_pixel(5, 5).0, [0, 0, 0]);
    }

    #[test]
    fn a_stereo_rig_shows_both_cameras() {
        use monohand_core::camera::Extrinsics;
        let left = cam();
        let right = cam().with_extrinsics(Extrinsics {
            translation: Vector3::new(-120.0, 0.0, 0.0),
            ..Extrinsics::default()
        });
        assert!((right.centre().x - 120.0).abs() < 1e-9);
        let tv = TopView::layout(640, 480, &[], &[left, right]);
        let mut f = RgbImage::new(640, 480);
        draw_top_view(&mut f, &[], &[left, right]);
        for c in [left, right] {
            let p = tv.to_pixel(c.centre().x, 0.0);
            assert_eq!(f.get_pixel(p[0] as u32, p[1] as u32).0, [230, 230, 230]);
        }
    }

    #[test]
    fn labels_of_hands_side_by_side_do_not_overlap() {
        // Two boxes wanted at the same place: the second goes above the first, or below it
        // when there is no room above; a third clears both.
        let size = [120.0, 20.0];
        let first = BBox::new(50.0, 100.0, 169.0, 119.0);
        let second = clear_of(&[first], [80.0, 105.0], size);
        assert_eq!(second, [80.0, 100.0 - 2.0 - 20.0]);
        let at_top = BBox::new(50.0, 0.0, 169.0, 19.0);
        assert_eq!(clear_of(&[at_top], [60.0, 5.0], size), [60.0, 22.0]);
        let b2 = BBox::new(80.0, 78.0, 199.0, 97.0);
        let third = clear_of(&[first, b2], [90.0, 100.0], size);
        let boxed = BBox::new(third[0], third[1], third[0] + 119.0, third[1] + 19.0);
        assert!(
            first.intersection_area(&boxed) == 0.0 && b2.intersection_area(&boxed) == 0.0,
            "{third:?}"
        );
        // Free: unchanged.
        assert_eq!(clear_of(&[first], [400.0, 100.0], size), [400.0, 100.0]);

        // Drawn: two hands side by side get two labels apart.
        let hands = [
            record(HandSide::Right, flat_hand(-20.0, 0.0, 420.0)),
            record(HandSide::Left, flat_hand(20.0, 0.0, 420.0)),
        ];
        let camera = Camera::pinhole(500.0, 500.0, 320.0, 240.0, 640, 480).unwrap();
        let mut frame = RgbImage::new(640, 480);
        let mut placed = Vec::new();
        for h in &hands {
            draw_hand_label(&mut frame, &camera, h, 2, &mut placed);
        }
        assert_eq!(placed.len(), 2);
        assert_eq!(placed[0].intersection_area(&placed[1]), 0.0, "{placed:?}");
    }

    #[test]
    fn labels_give_the_distance_in_cm() {
        let h = record(HandSide::Left, flat_hand(0.0, 0.0, 420.0));
        let d = hand_distance_mm(h.joints_3d_mm.as_ref().unwrap());
        assert!((d - 423.0).abs() < 5.0, "{d}");
        assert_eq!(hand_label_with_distance(&h), "L 42CM");
    }

    #[test]
    fn the_camera_source_is_shown_once_with_the_labels() {
        let camera = Camera::pinhole(500.0, 500.0, 319.5, 239.5, 640, 480).unwrap();
        let hands = [record(HandSide::Left, flat_hand(0.0, 0.0, 420.0))];
        let draw = |source: Option<&str>, layers: Layers| {
            let mut frame = RgbImage::new(640, 480);
            let mut r = SceneRenderer::default();
            r.set_camera_source(source);
            r.draw(&mut frame, &hands, &[camera], &layers);
            frame
        };
        let labels = Layers::only(&[Layer::Labels]);
        let with = draw(Some("exif+sensor-db"), labels);
        let without = draw(None, labels);
        // The label's light box sits at the bottom left (a 2% margin, 10 px; font scale 2
        // and its padding of 2 at 640x480), once.
        let light = |f: &RgbImage, x: u32, y: u32| f.get_pixel(x, y).0 == [220, 220, 220];
        let (tw, th) = text_size("CAMERA EXIF+SENSOR-DB", 2);
        let (top, bottom) = (480 - 10 - (th as u32 + 4), 480 - 10 - 1);
        let right = 10 + tw as u32 + 4 - 1;
        for (x, y) in [(10, top), (10, bottom), (right, top), (right, bottom)] {
            assert!(light(&with, x, y) && !light(&without, x, y), "({x}, {y})");
        }
        assert!(!light(&with, right + 1, bottom) && !light(&with, 10, bottom + 1));
        // Everything else is the same; without the labels layer it is not drawn.
        let differ = with
            .pixels()
            .zip(without.pixels())
            .filter(|(a, b)| a != b)
            .count();
        assert!(
            differ > 0 && differ <= (right as usize + 1) * 30,
            "{differ}"
        );
        let top = Layers::only(&[Layer::Top]);
        assert!(draw(Some("exif"), top) == draw(None, top));
    }

    #[test]
    fn bad_values_and_odd_frames_do_not_panic() {
        let mut j = flat_hand(0.0, 0.0, 400.0);
        j[3] = [f64::NAN, 0.0, 1.0];
        j[7] = [0.0, 0.0, -50.0];
        j[8] = [1e300, 0.0, 1e-300];
        let hands = [record(HandSide::Left, j)];
        let all = Layers::only(&Layer::ALL);
        let mut r = SceneRenderer::default();
        for (w, h) in [(0, 0), (1, 1), (7, 3), (640, 480), (320, 240)] {
            let mut f = RgbImage::new(w, h);
            r.draw(&mut f, &hands, &[], &all);
        }
        assert_eq!(nice_ceil(501.0), 750.0);
        assert_eq!(nice_ceil(2600.0), 3000.0);
        assert!(clip_segment([0.0, 0.0], [10.0, 0.0], BBox::new(20.0, -1.0, 30.0, 1.0)).is_none());
    }
}
