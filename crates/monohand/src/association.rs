//! Which hand in each view is which: the one association policy of `run` and `lift`.
//!
//! Views are taken in order. The hands of the **first view** (the reference camera, in
//! whose frame the 3D is written) are anchors. Every later view gives each anchor, taken
//! in order of the anchors' scores (best first), its best-scoring hand of the same side
//! not yet given to another anchor. A hand left over in a later view becomes an anchor
//! itself when no anchor has its side yet (the best-scoring one of that side), and is
//! matched in the views after it: a hand the first camera misses is still fitted from the
//! others.

use monohand_core::hand_model::HandSide;

/// One hand in one view, as association sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Left or right (for a tracked hand, the side voted over its frames).
    pub side: HandSide,
    /// Higher is more likely a real hand: the detector's score, or the keypoints' summed
    /// confidence when there is no detector.
    pub score: f64,
}

/// The hands of a frame: per hand, the `(view, hand index)` pairs that see it, its anchor
/// first. The first view's hands come first, in their order, then the anchors of later
/// views.
///
/// ```
/// use monohand::association::{associate, Candidate};
/// use monohand::HandSide::{Left, Right};
///
/// let c = |side, score| Candidate { side, score };
/// let first = [c(Left, 0.9)];
/// let second = [c(Right, 0.7), c(Left, 0.4), c(Left, 0.6)];
/// let views: [&[Candidate]; 2] = [&first, &second];
/// let hands = associate(&views);
/// // The left hand is matched to the second view's better left hand; the right hand only
/// // the second view sees is anchored there.
/// assert_eq!(hands, vec![vec![(0, 0), (1, 2)], vec![(1, 0)]]);
/// ```
pub fn associate(views: &[&[Candidate]]) -> Vec<Vec<(usize, usize)>> {
    let mut used: Vec<Vec<bool>> = views.iter().map(|h| vec![false; h.len()]).collect();
    let mut hands: Vec<Vec<(usize, usize)>> = Vec::new();
    let best_unused = |hands: &[Candidate], used: &[bool], side: HandSide| {
        hands
            .iter()
            .enumerate()
            .filter(|(k, o)| o.side == side && !used[*k])
            .max_by(|a, b| a.1.score.total_cmp(&b.1.score).then(b.0.cmp(&a.0)))
            .map(|(k, _)| k)
    };
    for (v, candidates) in views.iter().enumerate() {
        let anchors: Vec<usize> = if v == 0 {
            (0..candidates.len()).collect()
        } else {
            [HandSide::Left, HandSide::Right]
                .into_iter()
                .filter(|side| !hands.iter().any(|h| side_of(views, h[0]) == Some(*side)))
                .filter_map(|side| best_unused(candidates, &used[v], side))
                .collect()
        };
        for &k in &anchors {
            used[v][k] = true;
        }
        // The best-scoring anchor chooses first in every later view.
        let mut order: Vec<usize> = (0..anchors.len()).collect();
        order.sort_by(|&a, &b| {
            let score = |i: usize| candidates[anchors[i]].score;
            score(b).total_cmp(&score(a)).then(a.cmp(&b))
        });
        let mut new: Vec<Vec<(usize, usize)>> = anchors.iter().map(|&k| vec![(v, k)]).collect();
        for (w, later) in views.iter().enumerate().skip(v + 1) {
            for &i in &order {
                if let Some(m) = best_unused(later, &used[w], candidates[anchors[i]].side) {
                    used[w][m] = true;
                    new[i].push((w, m));
                }
            }
        }
        hands.extend(new);
    }
    hands
}

/// The side of hand `(v, k)`.
fn side_of(views: &[&[Candidate]], (v, k): (usize, usize)) -> Option<HandSide> {
    views.get(v)?.get(k).map(|c| c.side)
}

#[cfg(test)]
mod tests {
    use super::*;
    use HandSide::{Left, Right};

    fn c(side: HandSide, score: f64) -> Candidate {
        Candidate { side, score }
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
    fn empty_input_is_empty() {
        let second = [c(Right, 0.9)];
        assert_eq!(associate(&[&[], &second]), vec![vec![(1, 0)]]);
        assert!(associate(&[]).is_empty());
    }
}
