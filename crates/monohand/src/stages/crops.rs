//! Stages 1 and 2 over every view, with MediaPipe's crop tracking and hand identities, and,
//! with several calibrated views, crops from the hands fitted in 3D.

use crate::base::camera::StatedCamera;
use crate::base::clock::Instant;
use crate::base::errors::SourceError;
use crate::base::frame::{FittedGuide, HandId, ViewError, ViewHands, VisionFrame};
use monohand_core::bbox::BBox;
use monohand_core::camera::Camera;
use monohand_core::hand_model::NUM_JOINTS;
use monohand_vision::{CropSeed, Detections, HandPipeline, RgbImage};
use nalgebra::Vector3;
use std::sync::Arc;

/// A projected hand whose box has less than this fraction inside the view is not looked
/// for there.
pub const GUIDE_MIN_INSIDE: f64 = 0.5;

/// Per view: the hands of the previous frame, for the next crops.
#[derive(Debug, Default)]
struct ViewTracks {
    previous: Vec<CropSeed>,
    ids: Vec<HandId>,
    frames_since_detection: usize,
}

/// One view's work for a frame, decided before the networks run.
struct ViewJob<'a> {
    image: &'a RgbImage,
    lens: Option<Camera>,
    seeds: Vec<CropSeed>,
    ids: Vec<HandId>,
    detect_new: bool,
}

/// Runs the networks on the frames of one or several views and keeps each hand's identity.
///
/// With tracking (video), each hand of the previous frame is looked for again in the crop
/// its keypoints predict, the palm detector runs only when a hand is lost or every
/// `detect_every` frames while fewer than the most hands are tracked, and a continued hand
/// keeps its id. Without tracking, every frame is detected on its own and every hand gets a
/// new id.
pub struct CropTracker {
    pipeline: Arc<HandPipeline>,
    views: Vec<ViewTracks>,
    /// Per view, the camera whose rectified views the hands are read in
    /// ([`HandPipeline::track_through`]); `None`: crops of the image as it is.
    lenses: Vec<Option<Camera>>,
    tracking: bool,
    detect_every: usize,
    next_id: HandId,
    /// With two or more calibrated views: each view's camera in the first camera's frame,
    /// through which the hands fitted in 3D seed the next crops ([`CropTracker::guide`]).
    guide_cameras: Vec<Camera>,
    /// The hands fitted in the last frame, predicted to the next one.
    guides: Vec<FittedGuide>,
}

/// How the crop stage works, as the resolved settings say
/// ([`crate::ResolvedSettings::crops`]).
#[derive(Debug, Clone, PartialEq)]
pub struct CropSettings {
    /// Each hand of a frame is looked for again in the next frame's crop its keypoints
    /// predict (video); otherwise every frame is detected on its own.
    pub tracking: bool,
    /// While tracking, the palm detector looks for new hands every this many frames (at
    /// least 1) while fewer than the most hands are followed.
    pub detect_every: usize,
    /// Per view, the camera whose rectified views its hands are read in
    /// ([`CropTracker::rectify_through`]); empty: every view as it is.
    pub lenses: Vec<Option<Camera>>,
    /// Each view's camera in the first camera's frame, through which the hands fitted in
    /// 3D seed the next crops ([`CropTracker::guide_through`]); empty: not seeded.
    pub guide_cameras: Vec<Camera>,
}

impl CropTracker {
    /// A tracker for `views` cameras, tracking or not, looking for new hands, reading each
    /// view through its lens and seeded by the hands fitted in 3D as `settings` say: the
    /// crop stage of a session and of the engine.
    pub fn new(pipeline: Arc<HandPipeline>, views: usize, settings: CropSettings) -> CropTracker {
        let mut crops = CropTracker {
            pipeline,
            views: (0..views).map(|_| ViewTracks::default()).collect(),
            lenses: Vec::new(),
            tracking: settings.tracking,
            detect_every: settings.detect_every,
            next_id: 0,
            guide_cameras: Vec::new(),
            guides: Vec::new(),
        };
        crops.rectify_through(settings.lenses);
        crops.guide_through(settings.guide_cameras);
        crops
    }

    /// Seeds each view's crops with the hands fitted in 3D, projected through `cameras`
    /// (one per view, in the first camera's frame): once [`CropTracker::guide`] has given
    /// the fitted hands, a view that does not follow one of them itself looks for it where
    /// it projects, with that hand's identity; a view's own hand under a projected one takes
    /// its identity and keeps its own crop. Needs tracking and two or more cameras;
    /// otherwise nothing changes.
    pub fn guide_through(&mut self, cameras: Vec<Camera>) {
        if self.tracking && cameras.len() >= 2 {
            self.guide_cameras = cameras;
        }
    }

    /// Whether the hands fitted in 3D seed the crops ([`CropTracker::guide_through`]).
    pub fn is_guided(&self) -> bool {
        !self.guide_cameras.is_empty()
    }

    /// The hands fitted in the frame just processed, predicted to the next frame, for its
    /// crops (with [`CropTracker::guide_through`]).
    pub fn guide(&mut self, hands: Vec<FittedGuide>) {
        self.guides = hands;
    }

    /// Reads each view's hands in rectified views through its camera (`None`: crops of the
    /// image as it is); a camera for another frame size is scaled to the frames
    /// ([`Camera::scaled_to`]; a view whose frames it cannot describe is read unrectified).
    pub fn rectify_through(&mut self, lenses: Vec<Option<Camera>>) {
        self.lenses = lenses;
    }

    /// The camera view `v`'s hands are read through, for a frame of `size`.
    pub fn lens(&self, v: usize, size: (u32, u32)) -> Option<Camera> {
        sized_for(self.lenses.get(v).copied().flatten()?, size)
    }

    /// Whether frames are tracked (video) rather than detected each on its own.
    pub fn is_tracking(&self) -> bool {
        self.tracking
    }

    /// Wraps the detections of an independent image of one view, made elsewhere (for
    /// example on a thread pool): every hand gets a new id.
    pub fn assign(
        &mut self,
        index: u64,
        time_s: f64,
        detections: Result<Detections, ViewError>,
        vision_ms: f64,
    ) -> VisionFrame {
        let view = detections.map(|d| {
            let ids = (0..d.hands.len() as u64)
                .map(|k| self.next_id + k)
                .collect();
            self.next_id += d.hands.len() as u64;
            ViewHands { detections: d, ids }
        });
        VisionFrame {
            index,
            time_s,
            views: vec![view],
            vision_ms,
            focal: StatedCamera::None,
        }
    }

    /// Runs the networks on one frame of every view; `images[v]` is view `v`'s frame, or
    /// why it could not be read (which breaks that view's tracking). The views run side by
    /// side on rayon's threads; the result does not depend on how.
    pub fn process(
        &mut self,
        index: u64,
        time_s: f64,
        images: &[Result<&RgbImage, SourceError>],
    ) -> VisionFrame {
        let t = Instant::now();
        if self.views.len() < images.len() {
            self.views.resize_with(images.len(), ViewTracks::default);
        }
        let jobs: Vec<Result<ViewJob<'_>, ViewError>> = images
            .iter()
            .enumerate()
            .map(|(v, image)| match image {
                Ok(i) => Ok(self.job(v, i)),
                Err(e) => Err(ViewError::Unreadable(e.clone())),
            })
            .collect();
        let run = |job: &Result<ViewJob<'_>, ViewError>| {
            let job = job.as_ref().map_err(Clone::clone)?;
            if self.tracking {
                self.pipeline
                    .track_seeds(job.image, job.lens.as_ref(), &job.seeds, job.detect_new)
                    .map_err(ViewError::from)
            } else {
                self.pipeline
                    .detect_through(job.image, job.lens.as_ref())
                    .map(|d| (d, Vec::new()))
                    .map_err(ViewError::from)
            }
        };
        let results: Vec<_> = if jobs.len() > 1 && self.pipeline.parallel() {
            use rayon::prelude::*;
            jobs.par_iter().map(run).collect()
        } else {
            jobs.iter().map(run).collect()
        };
        let mut out = Vec::with_capacity(images.len());
        for (v, (job, result)) in jobs.into_iter().zip(results).enumerate() {
            out.push(self.commit(v, job, result));
        }
        VisionFrame {
            index,
            time_s,
            views: out,
            vision_ms: t.elapsed().as_secs_f64() * 1e3,
            focal: StatedCamera::None,
        }
    }

    /// View `v`'s seeds for this frame (its own hands of the previous frame, then the
    /// fitted hands it has not, projected) and whether its palm detector runs.
    fn job<'a>(&self, v: usize, image: &'a RgbImage) -> ViewJob<'a> {
        let lens = self.lens(v, image.dimensions());
        let state = &self.views[v];
        let mut seeds = state.previous.clone();
        let mut ids = state.ids.clone();
        if let Some(camera) = self.guide_camera(v, image.dimensions()) {
            guide_seeds(
                &camera,
                image.dimensions(),
                &self.guides,
                &mut seeds,
                &mut ids,
            );
        }
        let max_hands = self.pipeline.options.max_hands;
        let detect_new = !self.tracking
            || seeds.is_empty()
            || (seeds.len() < max_hands && state.frames_since_detection + 1 >= self.detect_every);
        ViewJob {
            image,
            lens,
            seeds,
            ids,
            detect_new,
        }
    }

    /// View `v`'s guide camera for a frame of `size`.
    fn guide_camera(&self, v: usize, size: (u32, u32)) -> Option<Camera> {
        sized_for(*self.guide_cameras.get(v)?, size)
    }

    /// Gives each hand view `v` found its identity (the seed's it continues, else a new one)
    /// and keeps them for the next frame.
    fn commit(
        &mut self,
        v: usize,
        job: Result<ViewJob<'_>, ViewError>,
        result: Result<(Detections, Vec<Option<usize>>), ViewError>,
    ) -> Result<ViewHands, ViewError> {
        let state = &mut self.views[v];
        let (job, (detections, origin)) = match (job, result) {
            (Ok(job), Ok(r)) => (job, r),
            (_, Err(e)) | (Err(e), _) => {
                state.previous.clear();
                state.ids.clear();
                return Err(e);
            }
        };
        let mut ids = Vec::with_capacity(detections.hands.len());
        for h in 0..detections.hands.len() {
            let id = origin
                .get(h)
                .copied()
                .flatten()
                .and_then(|s| job.ids.get(s));
            ids.push(match id {
                Some(&id) => id,
                None => {
                    self.next_id += 1;
                    self.next_id - 1
                }
            });
        }
        state.frames_since_detection = if job.detect_new {
            0
        } else {
            state.frames_since_detection + 1
        };
        if self.tracking {
            state.previous = detections.hands.iter().map(CropSeed::from_hand).collect();
            state.ids.clone_from(&ids);
        }
        Ok(ViewHands { detections, ids })
    }
}

/// `camera` for frames of `size` ([`Camera::scaled_to`] when its own size differs; `None`
/// where it cannot describe them).
fn sized_for(camera: Camera, size: (u32, u32)) -> Option<Camera> {
    let k = &camera.intrinsics;
    if (k.width, k.height) == size {
        Some(camera)
    } else {
        camera.scaled_to(size.0, size.1).ok()
    }
}

/// Seeds one view's crops with the fitted hands: a hand the view does not follow is looked
/// for where it projects, with its identity, when at least [`GUIDE_MIN_INSIDE`] of its box
/// falls inside the view. A hand the view follows itself (the same identity, or its own
/// hand whose box centre lies in the projected box, which takes the fitted hand's identity)
/// keeps its own keypoints for the crop. (On the dev rig, 4 views, every crop from the
/// fitted hand gave 11.2 mm absolute against 12.0, but the side view's keypoints then
/// disagreed with the others by a steady 6 px, twice as much as before, and the rig check
/// named that unchanged camera: docs/accuracy.md.)
fn guide_seeds(
    camera: &Camera,
    size: (u32, u32),
    guides: &[FittedGuide],
    seeds: &mut Vec<CropSeed>,
    ids: &mut Vec<HandId>,
) {
    let own = seeds.len();
    for guide in guides {
        let Some(projected) = project_seed(camera, size, &guide.joints) else {
            continue;
        };
        if ids.contains(&guide.id) {
            continue;
        }
        let bounds = BBox::around(projected.points);
        let mine = (0..own).find(|&k| {
            !guides.iter().any(|g| g.id == ids[k])
                && bounds.contains(BBox::around(seeds[k].points).centre())
        });
        match mine {
            Some(k) => ids[k] = guide.id,
            None => {
                seeds.push(projected);
                ids.push(guide.id);
            }
        }
    }
}

/// The grid projected keypoints are rounded to, pixels: a crop does not depend on the last
/// bits of the cameras' extrinsics, so that a rig's hands are the same whichever camera's
/// frame is the world (the extrinsics re-expressed in the first camera's frame differ by
/// rounding, about 1e-10 px once projected).
pub const SEED_GRID_PX: f64 = 1.0 / 64.0;

fn snap(x: f64) -> f64 {
    (x / SEED_GRID_PX).round() * SEED_GRID_PX
}

/// A fitted hand's joints projected into a view of `size` pixels, rounded to
/// [`SEED_GRID_PX`]: `None` when a joint is
/// behind the camera or less than [`GUIDE_MIN_INSIDE`] of the joints' box is inside the
/// view.
fn project_seed(
    camera: &Camera,
    size: (u32, u32),
    joints: &[Vector3<f64>; NUM_JOINTS],
) -> Option<CropSeed> {
    let mut points = [[0.0; 2]; NUM_JOINTS];
    for (p, x) in points.iter_mut().zip(joints) {
        let px = camera.project(x)?;
        *p = [snap(px.x), snap(px.y)];
    }
    let bounds = BBox::around(points);
    let view = BBox::new(-0.5, -0.5, f64::from(size.0) - 0.5, f64::from(size.1) - 0.5);
    let inside = bounds.intersection_area(&view) / bounds.area().max(1e-9);
    (bounds.is_finite() && inside >= GUIDE_MIN_INSIDE).then_some(CropSeed { points, score: 1.0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-sized set of joints around `centre` (mm, camera frame): 21 points on a
    /// 80 mm square.
    fn hand_at(centre: Vector3<f64>) -> [Vector3<f64>; NUM_JOINTS] {
        std::array::from_fn(|j| {
            let (a, b) = ((j % 5) as f64 / 4.0 - 0.5, (j / 5) as f64 / 4.0 - 0.5);
            centre + Vector3::new(80.0 * a, 80.0 * b, 0.0)
        })
    }

    fn seed_at(u: f64, v: f64) -> CropSeed {
        CropSeed {
            points: std::array::from_fn(|j| [u + (j % 5) as f64, v + (j / 5) as f64]),
            score: 0.9,
        }
    }

    #[test]
    fn a_fitted_hand_projects_into_the_views_that_see_it() {
        let camera = Camera::generic(640, 480).unwrap();
        let joints = hand_at(Vector3::new(0.0, 0.0, 500.0));
        let seed = project_seed(&camera, (640, 480), &joints).expect("in view");
        for (p, x) in seed.points.iter().zip(&joints) {
            let px = camera.project(x).unwrap();
            let near = |a: f64, b: f64| (a - b).abs() <= SEED_GRID_PX / 2.0;
            assert!(near(p[0], px.x) && near(p[1], px.y));
            assert_eq!(p[0], snap(p[0]));
        }
        // Mostly outside the view, or behind the camera: not looked for.
        let aside = hand_at(Vector3::new(420.0, 0.0, 500.0));
        assert!(project_seed(&camera, (640, 480), &aside).is_none());
        let behind = hand_at(Vector3::new(0.0, 0.0, -500.0));
        assert!(project_seed(&camera, (640, 480), &behind).is_none());
    }

    #[test]
    fn the_views_own_hand_under_a_fitted_hand_takes_its_identity_and_keeps_its_crop() {
        let camera = Camera::generic(640, 480).unwrap();
        let guide = FittedGuide {
            id: 7,
            joints: hand_at(Vector3::new(0.0, 0.0, 500.0)),
        };
        let projected = project_seed(&camera, (640, 480), &guide.joints).unwrap();
        // The view follows a hand of its own under the fitted one (id 3) and another one
        // far away (id 4).
        let mut seeds = vec![seed_at(318.0, 238.0), seed_at(20.0, 20.0)];
        let mut ids = vec![3, 4];
        guide_seeds(
            &camera,
            (640, 480),
            std::slice::from_ref(&guide),
            &mut seeds,
            &mut ids,
        );
        assert_eq!(ids, vec![7, 4]);
        assert_eq!(seeds, vec![seed_at(318.0, 238.0), seed_at(20.0, 20.0)]);
        // A view that does not follow it looks for it where it projects.
        let (mut seeds, mut ids) = (vec![seed_at(20.0, 20.0)], vec![4]);
        guide_seeds(&camera, (640, 480), &[guide], &mut seeds, &mut ids);
        assert_eq!(ids, vec![4, 7]);
        assert_eq!(seeds[1], projected);
    }
}
