//! 2D keypoints in, 3D hands out: the session's sibling for keypoints made elsewhere
//! (OpenPose, MediaPipe, the project's own JSON Lines).

use crate::stages::association::{associate, Candidate};
use crate::stages::fitter::fit::{fit_views, FitOutcome};
use monohand_core::prelude::*;

/// One hand of a frame after lifting.
#[derive(Debug)]
pub struct LiftedHand {
    /// Left or right.
    pub side: HandSide,
    /// The `(view, index into that view's observations)` pairs that see this hand, the
    /// first view's own first.
    pub views: Vec<(usize, usize)>,
    /// `(view, count)` for every view with more than one hand of this side: without
    /// identities the lifter follows one hand per side (the most confident in each view).
    pub crowded_views: Vec<(usize, usize)>,
    /// The fit, or why there is none.
    pub outcome: FitOutcome,
}

/// Fits 2D keypoints of one or several calibrated views to 3D hands, frame after frame.
///
/// The input has no hand identities, so the lifter follows one hand per side: in the first
/// view the most confident hand of each side (summed keypoint confidence) is kept, and the
/// views are associated by [`crate::association::associate`], the policy of the video
/// session (a side the first view misses is anchored in the next view that sees it). With tracking each side's fit starts from its previous one.
///
/// ```
/// use monohand::prelude::*;
/// use monohand::Lifter;
///
/// let camera = Camera::generic(640, 480)?;
/// let skeletons = [HandSkeleton::default_for(HandSide::Left), HandSkeleton::default_for(HandSide::Right)];
/// // A right hand 40 cm in front of the camera, seen as 2D keypoints.
/// let mut pose = HandPose::default();
/// pose.translation = nalgebra::Vector3::new(0.0, 0.0, 400.0);
/// let truth = forward_kinematics(&skeletons[1], &pose);
/// let points = truth.map(|x| {
///     let uv = camera.project(&x).expect("in front of the camera");
///     [uv.x, uv.y, 1.0]
/// });
/// let hand = HandObservation { side: HandSide::Right, keypoints: Keypoints2d { points }, cues: None };
///
/// let mut lifter = Lifter::new(vec![camera], skeletons, FitOptions::default(), false)?;
/// let hands = lifter.lift(&[&[hand]]);
/// let monohand::FitOutcome::Fitted(fit) = &hands[0].outcome else { panic!("no fit") };
/// assert!((fit.joints_3d[0] - truth[0]).norm() < 5.0); // the wrist, in mm
/// # Ok::<(), monohand::SessionError>(())
/// ```
pub struct Lifter {
    cameras: Vec<Camera>,
    trackers: [HandTracker; 2],
    tracking: bool,
}

impl Lifter {
    /// A lifter for these cameras (one per view, the first the reference), with the left
    /// and right hand models.
    pub fn new(
        cameras: Vec<Camera>,
        skeletons: [HandSkeleton; 2],
        options: FitOptions,
        tracking: bool,
    ) -> crate::SessionResult<Lifter> {
        if cameras.is_empty() {
            return Err(crate::SessionError::NoCamera);
        }
        for c in &cameras {
            c.validate()?;
        }
        Ok(Lifter {
            cameras,
            trackers: [
                HandTracker::new(skeletons[0], options)?,
                HandTracker::new(skeletons[1], options)?,
            ],
            tracking,
        })
    }

    /// The cameras, one per view.
    pub fn cameras(&self) -> &[Camera] {
        &self.cameras
    }

    /// Lifts one frame: `views[v]` holds view `v`'s hands (missing views give an empty
    /// slice). Returns at most one hand per side: those the first view sees (left first),
    /// then a side only later views see.
    pub fn lift(&mut self, views: &[&[HandObservation]]) -> Vec<LiftedHand> {
        let total = |h: &HandObservation| h.keypoints.points.iter().map(|p| p[2]).sum::<f64>();
        let candidates: Vec<Vec<Candidate>> = views
            .iter()
            .map(|hands| {
                hands
                    .iter()
                    .map(|h| Candidate {
                        side: h.side,
                        score: total(h),
                        id: None,
                    })
                    .collect()
            })
            .collect();
        let Some(first) = candidates.first() else {
            return Vec::new();
        };
        // One anchor per side in the first view: its most confident hand.
        let anchors: Vec<usize> = [HandSide::Left, HandSide::Right]
            .into_iter()
            .filter_map(|side| {
                (0..first.len())
                    .filter(|&k| first[k].side == side)
                    .max_by(|&a, &b| first[a].score.total_cmp(&first[b].score).then(b.cmp(&a)))
            })
            .collect();
        let anchored: Vec<Candidate> = anchors.iter().map(|&k| first[k]).collect();
        let mut slices: Vec<&[Candidate]> = candidates.iter().map(Vec::as_slice).collect();
        slices[0] = &anchored;
        let mut out = Vec::new();
        for mut pairs in associate(&slices) {
            // Back from the anchors to the first view's own indices.
            for pair in pairs.iter_mut().filter(|p| p.0 == 0) {
                if let Some(&k) = anchors.get(pair.1) {
                    *pair = (0, k);
                }
            }
            let Some(side) = pairs
                .first()
                .and_then(|&(v, k)| Some(views.get(v)?.get(k)?.side))
            else {
                continue;
            };
            let crowded_views = candidates
                .iter()
                .enumerate()
                .map(|(v, c)| (v, c.iter().filter(|c| c.side == side).count()))
                .filter(|&(_, n)| n > 1)
                .collect();
            let tracker = &mut self.trackers[usize::from(side == HandSide::Right)];
            if !self.tracking {
                tracker.reset();
            }
            let fit_views_in: Vec<View> = pairs
                .iter()
                .filter_map(|&(v, k)| {
                    let h = views.get(v)?.get(k)?;
                    Some(View::new(self.cameras.get(v)?, &h.keypoints).with_cues(h.cues.as_ref()))
                })
                .collect();
            let outcome = fit_views(tracker, &fit_views_in);
            out.push(LiftedHand {
                side,
                views: pairs,
                crowded_views,
                outcome,
            });
        }
        out
    }
}
