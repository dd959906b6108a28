//! Which hand in each view is which: the one association policy of `run` and `lift`.
//!
//! Views are taken in order. The hands of the **first view** (the reference camera, in
//! whose frame the 3D is written) are anchors. A hand may carry an **identity** that more
//! than one view gives it (a tracked hand fitted in 3D and looked for in every view where
//! it projects, [`crate::CropTracker::guide_through`]): the views that give the same
//! identity see the same hand, and such a hand is an anchor in the first view that sees it.
//! Every later view then gives each anchor it has no hand for, taken in order of the
//! anchors' scores (best first), its best-scoring hand of the same side not yet given to
//! another anchor and not bound to another identity. A hand left over in a later view
//! becomes an anchor itself when no anchor has its side yet (the best-scoring one of that
//! side), and is matched in the views after it: a hand the first camera misses is still
//! fitted from the others.

use monohand_core::camera::Camera;
use monohand_core::hand_model::{HandSide, NUM_JOINTS};
use monohand_core::observation::Keypoints2d;
use monohand_core::triangulation::triangulate;
use nalgebra::Point2;

/// One hand in one view, as association sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Left or right (for a tracked hand, the side voted over its frames).
    pub side: HandSide,
    /// Higher is more likely a real hand: the detector's score, or the keypoints' summed
    /// confidence when there is no detector.
    pub score: f64,
    /// The hand's identity, when it has one: candidates of different views with the same
    /// identity are the same hand.
    pub id: Option<u64>,
}

/// The hands of a frame: per hand, the `(view, hand index)` pairs that see it, its anchor
/// first. The first view's hands come first, in their order, then the anchors of later
/// views.
///
/// ```
/// use monohand::association::{associate, Candidate};
/// use monohand::HandSide::{Left, Right};
///
/// let c = |side, score| Candidate { side, score, id: None };
/// let first = [c(Left, 0.9)];
/// let second = [c(Right, 0.7), c(Left, 0.4), c(Left, 0.6)];
/// let views: [&[Candidate]; 2] = [&first, &second];
/// let hands = associate(&views);
/// // The left hand is matched to the second view's better left hand; the right hand only
/// // the second view sees is anchored there.
/// assert_eq!(hands, vec![vec![(0, 0), (1, 2)], vec![(1, 0)]]);
/// ```
pub fn associate(views: &[&[Candidate]]) -> Vec<Vec<(usize, usize)>> {
    associate_by(views, |_, (w, m)| Some(-views[w][m].score), true)
}

/// [`associate`] with another test of whether two hands of different views are the same:
/// `pair(anchor, other)` is `None` when they cannot be, else a cost (lower: the better
/// match; the anchor's best match is the unused hand of least cost). With `same_side`, only
/// hands of the anchor's side are tried; a hand bound to the anchor by identity must pass
/// `pair` too.
pub fn associate_by(
    views: &[&[Candidate]],
    pair: impl Fn((usize, usize), (usize, usize)) -> Option<f64>,
    same_side: bool,
) -> Vec<Vec<(usize, usize)>> {
    let mut used: Vec<Vec<bool>> = views.iter().map(|h| vec![false; h.len()]).collect();
    let mut hands: Vec<Vec<(usize, usize)>> = Vec::new();
    // An identity more than one view gives binds its hands together.
    let bound = |id: Option<u64>| {
        id.is_some_and(|id| {
            views
                .iter()
                .filter(|hands| hands.iter().any(|c| c.id == Some(id)))
                .count()
                >= 2
        })
    };
    let best_unused = |anchor: (usize, usize), w: usize, used: &[bool]| {
        let side = views[anchor.0][anchor.1].side;
        views[w]
            .iter()
            .enumerate()
            .filter(|(m, o)| !used[*m] && !bound(o.id) && (!same_side || o.side == side))
            .filter_map(|(m, _)| Some((m, pair(anchor, (w, m))?)))
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
            .map(|(m, _)| m)
    };
    let best_of_side = |v: usize, used: &[bool], side: HandSide| {
        views[v]
            .iter()
            .enumerate()
            .filter(|(k, o)| o.side == side && !used[*k] && !bound(o.id))
            .max_by(|a, b| a.1.score.total_cmp(&b.1.score).then(b.0.cmp(&a.0)))
            .map(|(k, _)| k)
    };
    for (v, candidates) in views.iter().enumerate() {
        let anchors: Vec<usize> = if v == 0 {
            (0..candidates.len()).collect()
        } else {
            let mut anchors: Vec<usize> = (0..candidates.len())
                .filter(|&k| !used[v][k] && bound(candidates[k].id))
                .collect();
            let taken = |side: HandSide, anchors: &[usize]| {
                hands.iter().any(|h| side_of(views, h[0]) == Some(side))
                    || anchors.iter().any(|&k| candidates[k].side == side)
            };
            for side in [HandSide::Left, HandSide::Right] {
                if !taken(side, &anchors) {
                    anchors.extend(best_of_side(v, &used[v], side));
                }
            }
            anchors
        };
        for &k in &anchors {
            used[v][k] = true;
        }
        // The same identity in later views first.
        let mut new: Vec<Vec<(usize, usize)>> = anchors.iter().map(|&k| vec![(v, k)]).collect();
        for (hand, &k) in new.iter_mut().zip(&anchors) {
            let Some(id) = candidates[k].id else { continue };
            for (w, later) in views.iter().enumerate().skip(v + 1) {
                let same = (0..later.len()).find(|&m| {
                    !used[w][m] && later[m].id == Some(id) && pair((v, k), (w, m)).is_some()
                });
                if let Some(m) = same {
                    used[w][m] = true;
                    hand.push((w, m));
                }
            }
        }
        // Then the best match: the best-scoring anchor chooses first in every later view.
        let mut order: Vec<usize> = (0..anchors.len()).collect();
        order.sort_by(|&a, &b| {
            let score = |i: usize| candidates[anchors[i]].score;
            score(b).total_cmp(&score(a)).then(a.cmp(&b))
        });
        for (w, used) in used.iter_mut().enumerate().skip(v + 1) {
            for &i in &order {
                if new[i].iter().any(|&(u, _)| u == w) {
                    continue;
                }
                if let Some(m) = best_unused((v, anchors[i]), w, used) {
                    used[m] = true;
                    new[i].push((w, m));
                }
            }
        }
        hands.extend(new);
    }
    hands
}

/// How well two views' keypoints of one hand agree with their cameras (both in one frame):
/// each joint both views see with at least `min_confidence` is triangulated from its two
/// rays and projected back, and the larger of its two reprojection errors taken; the
/// median over those joints, pixels (a joint triangulated behind a camera counts as
/// infinitely far; one whose rays are parallel is taken [`PARALLEL_RAY_DEPTH_MM`] along the
/// first view's ray). `None` with fewer than
/// [`AGREEMENT_MIN_JOINTS`] such joints.
pub fn agreement_px(
    a: (&Camera, &Keypoints2d),
    b: (&Camera, &Keypoints2d),
    min_confidence: f64,
) -> Option<f64> {
    let (centre_a, centre_b) = (a.0.centre(), b.0.centre());
    let (to_ref_a, to_ref_b) = (
        a.0.extrinsics.rotation.inverse(),
        b.0.extrinsics.rotation.inverse(),
    );
    let mut errors = [0.0; NUM_JOINTS];
    let mut n = 0;
    for (pa, pb) in a.1.points.iter().zip(&b.1.points) {
        if pa[2] < min_confidence || pb[2] < min_confidence {
            continue;
        }
        let (ua, ub) = (Point2::new(pa[0], pa[1]), Point2::new(pb[0], pb[1]));
        let error = || {
            let da = to_ref_a * a.0.ray(ua)?;
            let db = to_ref_b * b.0.ray(ub)?;
            // Rays too nearly parallel to meet (two cameras in one place): a point along
            // the first, where both cameras see the same direction whatever its depth.
            let x = triangulate(&[(centre_a, da, 1.0), (centre_b, db, 1.0)])
                .unwrap_or(centre_a + PARALLEL_RAY_DEPTH_MM * da);
            let ea = (a.0.project(&x)? - ua).norm();
            let eb = (b.0.project(&x)? - ub).norm();
            Some(ea.max(eb))
        };
        // A joint behind a camera counts as far off.
        errors[n] = error().unwrap_or(f64::INFINITY);
        n += 1;
    }
    if n < AGREEMENT_MIN_JOINTS {
        return None;
    }
    let errors = &mut errors[..n];
    errors.sort_by(f64::total_cmp);
    Some(errors[n / 2])
}

/// Two views' hands whose keypoints agree within this many pixels through the cameras
/// ([`agreement_px`]) are the same hand. On the 4 views of the dev rig, tracked, the pairs
/// of views seeing its one hand agree within 0.3-23.8 px (median 2.8, 95% within 10.8).
pub const SAME_HAND_PX: f64 = 30.0;

/// What a hand of the other side adds to its agreement when an anchor chooses among the
/// hands that agree with it: the same side wins among hands that both agree (two hands
/// side by side along a stereo pair's baseline agree with each other's rays too), and a
/// hand whose side one view got wrong is still matched.
pub const SIDE_PENALTY_PX: f64 = 10.0;

/// Where [`agreement_px`] takes a joint whose two rays are too nearly parallel to meet
/// (less than about 0.1 degree apart: the two cameras in one place), mm along the first
/// view's ray.
pub const PARALLEL_RAY_DEPTH_MM: f64 = 1000.0;

/// The fewest joints [`agreement_px`] compares.
pub const AGREEMENT_MIN_JOINTS: usize = 5;

/// The side of hand `(v, k)`.
fn side_of(views: &[&[Candidate]], (v, k): (usize, usize)) -> Option<HandSide> {
    views.get(v)?.get(k).map(|c| c.side)
}

#[cfg(test)]
mod tests {
    use super::*;
    use HandSide::{Left, Right};

    fn c(side: HandSide, score: f64) -> Candidate {
        Candidate {
            side,
            score,
            id: None,
        }
    }

    fn with_id(side: HandSide, score: f64, id: u64) -> Candidate {
        Candidate {
            side,
            score,
            id: Some(id),
        }
    }

    #[test]
    fn views_giving_the_same_identity_see_one_hand_whatever_its_side() {
        // The second view calls the hand left (id 7, like the first view's right hand): the
        // identity wins over the side; its other left hand is matched to the left anchor.
        let first = [with_id(Right, 0.9, 7), with_id(Left, 0.8, 1)];
        let second = [with_id(Left, 0.3, 7), with_id(Left, 0.9, 4)];
        let m = associate(&[&first, &second]);
        assert_eq!(m, vec![vec![(0, 0), (1, 0)], vec![(0, 1), (1, 1)]]);
    }

    #[test]
    fn a_hand_bound_by_identity_in_later_views_is_fitted_even_when_its_side_is_taken() {
        // The first view has its own right hand (id 3); views 2 and 3 follow the fitted
        // right hand 9, which the first view lost: two hands, neither split.
        let first = [with_id(Right, 0.9, 3)];
        let second = [with_id(Right, 0.8, 9)];
        let third = [with_id(Right, 0.7, 9), with_id(Right, 0.5, 12)];
        let m = associate(&[&first, &second, &third]);
        assert_eq!(m, vec![vec![(0, 0), (2, 1)], vec![(1, 0), (2, 0)]]);
    }

    #[test]
    fn the_better_anchor_chooses_first_and_no_hand_is_given_twice() {
        // Two left hands in the first view; the second view has one left hand.
        let first = [c(Left, 0.5), c(Left, 0.9)];
        let second = [c(Left, 0.8)];
        let m = associate(&[&first, &second]);
        assert_eq!(m, vec![vec![(0, 0)], vec![(0, 1), (1, 0)]]);
    }

    #[test]
    fn a_side_the_first_view_misses_is_anchored_in_the_next_view_that_sees_it() {
        // The third view sees the right hand too; a second left hand in view 2 is not
        // anchored (the left side has its anchor in the first view).
        let first = [c(Left, 0.9)];
        let second = [c(Left, 0.9), c(Right, 0.3), c(Left, 0.5), c(Right, 0.6)];
        let third = [c(Right, 0.8), c(Left, 0.2)];
        let m = associate(&[&first, &second, &third]);
        assert_eq!(m, vec![vec![(0, 0), (1, 0), (2, 1)], vec![(1, 3), (2, 0)]]);
    }

    #[test]
    fn two_views_of_one_hand_agree_and_of_two_hands_do_not() {
        use nalgebra::{Rotation3, Vector3};
        let left = Camera::generic(640, 480).unwrap();
        // A second camera 300 mm to the right, turned 30 degrees towards the hand.
        let rotation = Rotation3::from_axis_angle(&Vector3::y_axis(), 30f64.to_radians());
        let right = left.with_extrinsics(monohand_core::camera::Extrinsics {
            rotation,
            translation: -(rotation * Vector3::new(300.0, 0.0, 0.0)),
        });
        let hand = |centre: Vector3<f64>| -> [Vector3<f64>; NUM_JOINTS] {
            std::array::from_fn(|j| {
                centre
                    + Vector3::new(
                        (j % 5) as f64 * 20.0,
                        (j / 5) as f64 * 20.0,
                        (j % 3) as f64 * 10.0,
                    )
            })
        };
        let seen = |cam: &Camera, joints: &[Vector3<f64>; NUM_JOINTS]| Keypoints2d {
            points: joints.map(|x| {
                let p = cam.project(&x).unwrap();
                [p.x, p.y, 0.9]
            }),
        };
        let one = hand(Vector3::new(0.0, 0.0, 600.0));
        let other = hand(Vector3::new(0.0, 150.0, 600.0));
        let same = agreement_px(
            (&left, &seen(&left, &one)),
            (&right, &seen(&right, &one)),
            0.1,
        );
        assert!(same.unwrap() < 1e-6, "{same:?}");
        let two = agreement_px(
            (&left, &seen(&left, &one)),
            (&right, &seen(&right, &other)),
            0.1,
        );
        assert!(two.unwrap() > SAME_HAND_PX, "{two:?}");
        // Too few joints seen with confidence: no verdict.
        let mut faint = seen(&right, &one);
        for p in faint.points.iter_mut().skip(3) {
            p[2] = 0.05;
        }
        assert!(agreement_px((&left, &seen(&left, &one)), (&right, &faint), 0.1).is_none());
    }

    #[test]
    fn empty_input_is_empty() {
        let second = [c(Right, 0.9)];
        assert_eq!(associate(&[&[], &second]), vec![vec![(1, 0)]]);
        assert!(associate(&[]).is_empty());
    }
}
