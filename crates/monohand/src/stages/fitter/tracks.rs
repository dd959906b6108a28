//! The hands followed over the frames: each identity's voted side, its 3D tracker and its
//! filters, forgotten after [`FORGET_AFTER_FRAMES`] frames unseen.

use crate::base::frame::{FittedGuide, HandId, VisionFrame};
use crate::stages::association::{
    agreement_px, associate, associate_by, Candidate, SAME_HAND_PX, SIDE_PENALTY_PX,
};
use crate::stages::fitter::options::{FitSettings, FORGET_AFTER_FRAMES};
use monohand_core::filtering::{DepthFilter, OneEuroFilter, OneEuroParams};
use monohand_core::prelude::*;
use monohand_vision::DetectedHand;
use nalgebra::Vector3;
use std::collections::HashMap;

/// The mean of a hand's joints.
fn mean(joints: &[Vector3<f64>; NUM_JOINTS]) -> Vector3<f64> {
    joints.iter().sum::<Vector3<f64>>() / NUM_JOINTS as f64
}

/// One hand followed over the frames.
pub(crate) struct Track {
    pub tracker: HandTracker,
    pub side: HandSide,
    /// Sum of the log-odds of "right" over the frames seen: one uncertain frame does not
    /// flip a hand.
    right_log_odds: f64,
    last_seen: u64,
    pub filter: Option<OneEuroFilter<NUM_JOINTS>>,
    pub depth: Option<DepthFilter>,
    /// Its last two fits' joints (first camera's frame) with their frame numbers, newest
    /// first: where the next frame's crops look for it ([`Tracks::guides`]).
    fitted: [Option<(u64, [Vector3<f64>; NUM_JOINTS])>; 2],
}

/// A hand of the first view that sees it: its id, side and the `(view, index)` pairs that
/// see it.
pub(crate) type Anchored = (HandId, HandSide, Vec<(usize, usize)>);

/// Index of a side in `[left, right]` arrays.
pub(crate) fn side_index(side: HandSide) -> usize {
    match side {
        HandSide::Left => 0,
        HandSide::Right => 1,
    }
}

/// The identities [`Tracks::separate`] gives hands split off another's: from here up, beyond
/// any the crop stage gives (one per new hand, from 0), and exact in JSON's numbers.
pub(crate) const SPLIT_IDS: HandId = 1 << 32;

/// Every hand followed, by identity, with the filters each new one gets.
pub(crate) struct Tracks {
    by_id: HashMap<HandId, Track>,
    smoothing: Option<OneEuroParams>,
    depth_filter: Option<OneEuroParams>,
    /// The identity of the `n`-th hand of a frame that the crops gave identity `id` too
    /// (`(id, n)`, `n` from 1): kept, so that it stays the same hand over the frames.
    split: HashMap<(HandId, usize), HandId>,
}

impl Tracks {
    /// No hand yet; new hands get the smoothing and depth filter of `settings` (resolved:
    /// the depth filter only while tracking, and not offline).
    pub(crate) fn new(settings: &FitSettings) -> Tracks {
        Tracks {
            by_id: HashMap::new(),
            smoothing: settings.smoothing,
            depth_filter: settings.depth_filter,
            split: HashMap::new(),
        }
    }

    /// Gives each of a frame's associated `hands` its own identity. The crops give a view's
    /// hand the identity of the fitted hand that projects onto it; when its keypoints then
    /// do not agree with that hand's other views (a view out of sync, a camera moved), it is
    /// fitted as a hand of its own, and would share the identity and the track of the
    /// other. The first hand keeps the identity; each later one gets one of its own
    /// ([`SPLIT_IDS`]; the same one while the split lasts) and a track voted from its views'
    /// hands (`detected`).
    pub(crate) fn separate<'f>(
        &mut self,
        hands: &mut [Anchored],
        index: u64,
        prototypes: &[HandTracker; 2],
        detected: impl Fn(usize, usize) -> Option<&'f DetectedHand>,
    ) {
        // No hand takes an identity another hand of the frame has or comes with.
        let given: std::collections::HashSet<HandId> = hands.iter().map(|h| h.0).collect();
        let mut used = std::collections::HashSet::new();
        for (id, _, views) in hands.iter_mut() {
            if used.insert(*id) {
                continue;
            }
            let mut n = 1;
            let own = loop {
                let next = SPLIT_IDS + self.split.len() as HandId;
                let own = *self.split.entry((*id, n)).or_insert(next);
                if !used.contains(&own) && !given.contains(&own) {
                    break own;
                }
                n += 1;
            };
            used.insert(own);
            *id = own;
            for &(v, k) in views.iter() {
                if let Some(hand) = detected(v, k) {
                    self.vote(own, hand, index, prototypes);
                }
            }
        }
    }

    /// The side voted for hand `id`, if it is followed.
    pub(crate) fn side(&self, id: HandId) -> Option<HandSide> {
        self.by_id.get(&id).map(|t| t.side)
    }

    /// Hand `id`'s track.
    pub(crate) fn get_mut(&mut self, id: &HandId) -> Option<&mut Track> {
        self.by_id.get_mut(id)
    }

    /// Counts frame `index`'s vote of the network for hand `id` (a new hand gets a track
    /// from `prototypes[side]`); a hand whose voted side flips starts again from the other
    /// side's prototype, its filters reset.
    pub(crate) fn vote(
        &mut self,
        id: HandId,
        hand: &DetectedHand,
        index: u64,
        prototypes: &[HandTracker; 2],
    ) {
        let p = f64::from(hand.side_score).clamp(0.5, 0.999);
        let p_right = if hand.side == HandSide::Right {
            p
        } else {
            1.0 - p
        };
        let log_odds = (p_right / (1.0 - p_right)).ln();
        let (smoothing, depth) = (self.smoothing, self.depth_filter);
        let track = self.by_id.entry(id).or_insert_with(|| Track {
            tracker: prototypes[side_index(hand.side)].clone(),
            side: hand.side,
            right_log_odds: 0.0,
            last_seen: index,
            filter: smoothing.map(OneEuroFilter::new),
            depth: depth.map(DepthFilter::new),
            fitted: [None, None],
        });
        track.right_log_odds += log_odds;
        track.last_seen = index;
        let voted = if track.right_log_odds >= 0.0 {
            HandSide::Right
        } else {
            HandSide::Left
        };
        if voted != track.side {
            track.side = voted;
            track.tracker = prototypes[side_index(voted)].clone();
            if let Some(f) = &mut track.filter {
                f.reset();
            }
            if let Some(f) = &mut track.depth {
                f.reset();
            }
            track.fitted = [None, None];
        }
    }

    /// Keeps hand `id`'s fit of frame `index` for the next frame's crops.
    pub(crate) fn fitted(&mut self, id: HandId, index: u64, joints: &[Vector3<f64>; NUM_JOINTS]) {
        if let Some(t) = self.by_id.get_mut(&id) {
            t.fitted = [Some((index, *joints)), t.fitted[0]];
        }
    }

    /// The hands fitted in frame `index`, predicted to the next frame: moved by their
    /// joints' mean motion since the frame before when they were fitted in both (the
    /// hand's shape is this frame's), in the order of their identities.
    pub(crate) fn guides(&self, index: u64) -> Vec<FittedGuide> {
        let mut out: Vec<FittedGuide> = self
            .by_id
            .iter()
            // A hand split off from another's identity ([`Tracks::separate`]) was fitted
            // from a view that disagrees with the others (out of sync, moved): put into
            // the other views it would find the hand they already see a second time.
            .filter(|(&id, _)| id < SPLIT_IDS)
            .filter_map(|(&id, t)| {
                let (i, joints) = t.fitted[0].filter(|(i, _)| *i == index)?;
                let motion = match t.fitted[1] {
                    Some((j, before)) if j + 1 == i => mean(&joints) - mean(&before),
                    _ => Vector3::zeros(),
                };
                Some(FittedGuide {
                    id,
                    joints: joints.map(|x| x + motion),
                })
            })
            .collect();
        out.sort_by_key(|g| g.id);
        out
    }

    /// Forgets the hands unseen for [`FORGET_AFTER_FRAMES`] frames at frame `index`.
    pub(crate) fn forget_unseen(&mut self, index: u64) {
        self.by_id
            .retain(|_, t| index.saturating_sub(t.last_seen) < FORGET_AFTER_FRAMES);
    }

    /// The frame's hands ([`associate_by`]): per hand its id, side (voted over its track)
    /// and the views that see it. With a calibrated camera per view, two views' hands are
    /// the same hand when their keypoints agree through the cameras ([`agreement_px`] within
    /// [`SAME_HAND_PX`]), whatever sides the network gave them; otherwise by side.
    pub(crate) fn associate(
        &self,
        frame: &VisionFrame,
        cameras: &[Camera],
        min_confidence: f64,
    ) -> Vec<Anchored> {
        let side = |id: &HandId, h: &DetectedHand| self.side(*id).unwrap_or(h.side);
        let candidates: Vec<Vec<Candidate>> = frame
            .views
            .iter()
            .map(|v| match v {
                Ok(vh) => vh
                    .detections
                    .hands
                    .iter()
                    .zip(&vh.ids)
                    .map(|(h, id)| Candidate {
                        side: side(id, h),
                        score: f64::from(h.detection_score),
                        id: Some(*id),
                    })
                    .collect(),
                Err(_) => Vec::new(),
            })
            .collect();
        let slices: Vec<&[Candidate]> = candidates.iter().map(Vec::as_slice).collect();
        let keypoints = |(v, k): (usize, usize)| {
            let vh = frame.views.get(v)?.as_ref().ok()?;
            Some((cameras.get(v)?, &vh.detections.hands.get(k)?.keypoints))
        };
        let hands = if cameras.len() >= 2 && cameras.len() >= frame.views.len() {
            let pair = |a: (usize, usize), b: (usize, usize)| {
                let e = agreement_px(keypoints(a)?, keypoints(b)?, min_confidence)?;
                let other_side = candidates[a.0][a.1].side != candidates[b.0][b.1].side;
                (e <= SAME_HAND_PX).then_some(e + if other_side { SIDE_PENALTY_PX } else { 0.0 })
            };
            associate_by(&slices, pair, false)
        } else {
            associate(&slices)
        };
        hands
            .into_iter()
            .filter_map(|views| {
                let (v, k) = *views.first()?;
                let id = *frame.views.get(v)?.as_ref().ok()?.ids.get(k)?;
                Some((id, candidates[v][k].side, views))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_hand_of_a_frame_gets_an_identity_of_its_own() {
        let settings = FitSettings::default();
        let prototype = |k: usize| {
            HandTracker::new(settings.skeletons[k], settings.options).expect("a tracker")
        };
        let prototypes = [prototype(0), prototype(1)];
        let mut tracks = Tracks::new(&settings);
        let right = |id| (id, HandSide::Right, Vec::new());
        let ids = |hands: &[Anchored]| hands.iter().map(|h| h.0).collect::<Vec<_>>();
        // A view's hand fitted on its own under hand 0's identity: a new one.
        let mut hands = vec![right(0), right(0), right(7)];
        tracks.separate(&mut hands, 0, &prototypes, |_, _| None);
        assert_eq!(ids(&hands), [0, SPLIT_IDS, 7]);
        // The same split next frame keeps it; a third hand under 0 gets another, and so
        // does a hand under 0 when one comes with the split's identity from its crop.
        let mut hands = vec![right(0), right(0), right(0)];
        tracks.separate(&mut hands, 1, &prototypes, |_, _| None);
        assert_eq!(ids(&hands), [0, SPLIT_IDS, SPLIT_IDS + 1]);
        let mut hands = vec![right(0), right(SPLIT_IDS), right(0)];
        tracks.separate(&mut hands, 2, &prototypes, |_, _| None);
        assert_eq!(ids(&hands), [0, SPLIT_IDS, SPLIT_IDS + 1]);
    }
}
