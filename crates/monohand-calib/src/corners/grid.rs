//! Assembling saddle candidates into a chessboard grid: a 3x3 seed around a candidate
//! (its neighbours both ways along two directions and the four diagonal ones, the four
//! squares between them alternating dark and light), grown a whole row or column at a
//! time on each side (each new corner predicted from the last three of its line, the
//! nearest candidate taken, or the strongest response near the prediction; the new
//! squares must continue the alternation) until no side grows.

use super::detect::{Candidate, RING_RADIUS};
use super::plane::Plane;
use nalgebra::Vector2;

type V2 = Vector2<f64>;

/// Corners closer than this (detection-level pixels) are not neighbours: the ring of the
/// response does not fit in smaller squares.
const MIN_SPACING: f64 = 6.0;
/// A corner is searched within this fraction of the local spacing of its prediction.
const SEARCH_RADIUS: f64 = 0.35;
/// Grids stop growing at this many corners along a side.
const MAX_SIDE: usize = 80;
/// Seeds tried at most.
const MAX_SEEDS: usize = 600;

/// A grid of corners, row-major.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Grid {
    pub rows: usize,
    pub cols: usize,
    pub pts: Vec<V2>,
}

impl Grid {
    #[inline]
    pub fn at(&self, r: usize, c: usize) -> V2 {
        self.pts[r * self.cols + c]
    }

    pub fn transpose(&self) -> Grid {
        let mut pts = Vec::with_capacity(self.pts.len());
        for c in 0..self.cols {
            for r in 0..self.rows {
                pts.push(self.at(r, c));
            }
        }
        Grid {
            rows: self.cols,
            cols: self.rows,
            pts,
        }
    }

    /// The rows in reverse order.
    pub fn flip_rows(&self) -> Grid {
        let mut pts = Vec::with_capacity(self.pts.len());
        for r in (0..self.rows).rev() {
            pts.extend_from_slice(&self.pts[r * self.cols..(r + 1) * self.cols]);
        }
        Grid { pts, ..*self }
    }

    /// Each row reversed.
    pub fn flip_cols(&self) -> Grid {
        let mut pts = Vec::with_capacity(self.pts.len());
        for r in 0..self.rows {
            pts.extend(self.pts[r * self.cols..(r + 1) * self.cols].iter().rev());
        }
        Grid { pts, ..*self }
    }

    /// The grey level of the square whose top-left corner (in grid order) is `(r, c)`:
    /// the mean of five samples (its centre and halfway to each of its corners).
    pub fn cell_value(&self, img: &Plane, r: usize, c: usize) -> f64 {
        let q = [
            self.at(r, c),
            self.at(r, c + 1),
            self.at(r + 1, c),
            self.at(r + 1, c + 1),
        ];
        let m = (q[0] + q[1] + q[2] + q[3]) * 0.25;
        let mut s = img.sample(m.x, m.y);
        for p in q {
            let h = (m + p) * 0.5;
            s += img.sample(h.x, h.y);
        }
        s / 5.0
    }

    /// Whether the squares alternate: `Some(true)` if every square `(r, c)` with `r + c`
    /// even is lighter than its neighbours by at least `min_contrast`, `Some(false)` if
    /// darker, `None` otherwise. Only the squares of rows `first_row..` are compared.
    pub fn alternation(&self, img: &Plane, first_row: usize, min_contrast: f64) -> Option<bool> {
        if self.rows < 2 || self.cols < 2 {
            return None;
        }
        let (cr, cc) = (self.rows - 1, self.cols - 1);
        let mut v = vec![0.0; cr * cc];
        for r in first_row..cr {
            for c in 0..cc {
                v[r * cc + c] = self.cell_value(img, r, c);
            }
        }
        let mut sign: Option<bool> = None;
        for r in first_row..cr {
            for c in 0..cc {
                let here = v[r * cc + c];
                let even = (r + c) % 2 == 0;
                let mut pairs = [None, None];
                if c + 1 < cc {
                    pairs[0] = Some(v[r * cc + c + 1]);
                }
                if r + 1 < cr {
                    pairs[1] = Some(v[(r + 1) * cc + c]);
                }
                for other in pairs.into_iter().flatten() {
                    let d = if even { here - other } else { other - here };
                    if d.abs() < min_contrast {
                        return None;
                    }
                    match sign {
                        None => sign = Some(d > 0.0),
                        Some(s) if s != (d > 0.0) => return None,
                        _ => {}
                    }
                }
            }
        }
        sign
    }
}

/// A grid found, and whether it stopped growing at the image's edge.
#[derive(Debug, Clone)]
pub(crate) struct Assembled {
    pub grid: Grid,
    /// Some side could not grow because its next corners would be out of the image.
    pub cut: bool,
}

enum Growth {
    Grown,
    Cut,
    Stopped,
}

/// Candidates bucketed by position.
struct Buckets {
    cell: f64,
    nx: usize,
    ny: usize,
    items: Vec<Vec<usize>>,
}

impl Buckets {
    fn new(cands: &[Candidate], w: usize, h: usize, cell: f64) -> Buckets {
        let nx = (w as f64 / cell).ceil().max(1.0) as usize;
        let ny = (h as f64 / cell).ceil().max(1.0) as usize;
        let mut items = vec![Vec::new(); nx * ny];
        for (i, c) in cands.iter().enumerate() {
            let (bx, by) = (
                ((c.p.x / cell).max(0.0) as usize).min(nx - 1),
                ((c.p.y / cell).max(0.0) as usize).min(ny - 1),
            );
            items[by * nx + bx].push(i);
        }
        Buckets {
            cell,
            nx,
            ny,
            items,
        }
    }

    /// Indices of candidates in the buckets overlapping the square `p +- radius`.
    fn around(&self, p: V2, radius: f64) -> impl Iterator<Item = usize> + '_ {
        let lo = |v: f64, n: usize| (((v - radius) / self.cell).floor().max(0.0) as usize).min(n);
        let hi = |v: f64, n: usize| {
            ((((v + radius) / self.cell).floor().max(-1.0) + 1.0) as usize).min(n)
        };
        let (x0, x1) = (lo(p.x, self.nx), hi(p.x, self.nx));
        let (y0, y1) = (lo(p.y, self.ny), hi(p.y, self.ny));
        (y0..y1).flat_map(move |by| {
            (x0..x1).flat_map(move |bx| self.items[by * self.nx + bx].iter().copied())
        })
    }
}

/// What the grid assembly works on.
pub(crate) struct Assembler<'a> {
    /// The smoothed detection level (colours of squares).
    pub img: &'a Plane,
    /// Its ChESS response (second chances for corners with no candidate).
    pub response: &'a Plane,
    /// The candidates, strongest first.
    pub cands: &'a [Candidate],
    /// The least grey-level difference between adjacent squares.
    pub min_contrast: f64,
    /// The least response of a corner with no candidate.
    pub fill_threshold: f32,
}

impl Assembler<'_> {
    /// The largest grid found; stops early at one of `target`'s size (either way round).
    pub fn assemble(&self, target: (usize, usize)) -> Option<Assembled> {
        let buckets = Buckets::new(self.cands, self.img.w, self.img.h, 16.0);
        let mut seeded = vec![false; self.cands.len()];
        let mut best: Option<Assembled> = None;
        let mut tried = 0;
        for i in 0..self.cands.len() {
            if seeded[i] {
                continue;
            }
            tried += 1;
            if tried > MAX_SEEDS {
                break;
            }
            let mut used = vec![false; self.cands.len()];
            let Some(grid) = self.seed(i, &buckets, &mut used) else {
                continue;
            };
            let found = self.grow(grid, &buckets, &mut used);
            for (s, u) in seeded.iter_mut().zip(&used) {
                *s |= *u;
            }
            let (r, c) = (found.grid.rows, found.grid.cols);
            let matches = (r, c) == target || (c, r) == target;
            let better = best
                .as_ref()
                .is_none_or(|b| found.grid.pts.len() > b.grid.pts.len());
            if matches {
                return Some(found);
            }
            if better {
                best = Some(found);
            }
        }
        best
    }

    fn nearest(&self, buckets: &Buckets, p: V2, radius: f64, used: &[bool]) -> Option<usize> {
        let mut best = None;
        let mut best_d = radius * radius;
        for i in buckets.around(p, radius) {
            if used[i] {
                continue;
            }
            let d = (self.cands[i].p - p).norm_squared();
            if d <= best_d {
                best_d = d;
                best = Some(i);
            }
        }
        best
    }

    /// A 3x3 grid around candidate `i`, or `None`.
    fn seed(&self, i: usize, buckets: &Buckets, used: &mut [bool]) -> Option<Grid> {
        let c = self.cands[i].p;
        // Nearest neighbours, up to 8, from rings of buckets of growing size.
        let mut radius = buckets.cell;
        let mut near: Vec<(f64, usize)> = Vec::new();
        while radius <= 256.0 {
            near.clear();
            near.extend(buckets.around(c, radius).filter_map(|j| {
                let d = (self.cands[j].p - c).norm();
                (j != i && d >= MIN_SPACING && d <= radius).then_some((d, j))
            }));
            if near.len() >= 8 {
                break;
            }
            radius *= 2.0;
        }
        near.sort_by(|a, b| a.0.total_cmp(&b.0));
        near.truncate(8);
        used[i] = true;
        for ia in 0..near.len().min(3) {
            let (la, ja) = near[ia];
            let a = self.cands[ja].p - c;
            used[ja] = true;
            let opp_a = self.nearest(buckets, c - a, SEARCH_RADIUS * la, used);
            let Some(opp_a) = opp_a else {
                used[ja] = false;
                continue;
            };
            used[opp_a] = true;
            for (ib, &(lb, jb)) in near.iter().enumerate() {
                if ib == ia || used[jb] {
                    continue;
                }
                let b = self.cands[jb].p - c;
                let sin = (a.x * b.y - a.y * b.x) / (la * lb);
                if sin.abs() < 0.35 || lb > 3.0 * la || la > 3.0 * lb {
                    continue;
                }
                used[jb] = true;
                if let Some(g) = self.seed_with(c, [ja, opp_a, jb], buckets, used) {
                    return Some(g);
                }
                used[jb] = false;
            }
            used[ja] = false;
            used[opp_a] = false;
        }
        used[i] = false;
        None
    }

    /// The 3x3 seed from the centre `c`, its neighbours `+a`, `-a` and `+b` (marked used);
    /// finds `-b` and the diagonals, checks the squares.
    fn seed_with(
        &self,
        c: V2,
        [ja, opp_a, jb]: [usize; 3],
        buckets: &Buckets,
        used: &mut [bool],
    ) -> Option<Grid> {
        let pa = self.cands[ja].p;
        let qa = self.cands[opp_a].p;
        let pb = self.cands[jb].p;
        let lb = (pb - c).norm();
        let la = (pa - c).norm();
        let qb_i = self.nearest(buckets, c - (pb - c), SEARCH_RADIUS * lb, used)?;
        used[qb_i] = true;
        let qb = self.cands[qb_i].p;
        let tol = SEARCH_RADIUS * la.min(lb);
        let mut taken = vec![qb_i];
        let mut diag = [V2::zeros(); 4];
        for (k, (sa, sb)) in [(qa, qb), (pa, qb), (qa, pb), (pa, pb)]
            .into_iter()
            .enumerate()
        {
            match self.nearest(buckets, sa + sb - c, tol, used) {
                Some(j) => {
                    used[j] = true;
                    taken.push(j);
                    diag[k] = self.cands[j].p;
                }
                None => {
                    taken.iter().for_each(|&j| used[j] = false);
                    return None;
                }
            }
        }
        let grid = Grid {
            rows: 3,
            cols: 3,
            pts: vec![diag[0], qb, diag[1], qa, c, pa, diag[2], pb, diag[3]],
        };
        if grid.alternation(self.img, 0, self.min_contrast).is_some() {
            Some(grid)
        } else {
            taken.iter().for_each(|&j| used[j] = false);
            None
        }
    }

    /// Grows `grid` on all sides until none grows.
    fn grow(&self, mut grid: Grid, buckets: &Buckets, used: &mut [bool]) -> Assembled {
        let mut done = [false; 4];
        let mut cut = false;
        loop {
            let mut grown = false;
            for (side, done) in done.iter_mut().enumerate() {
                if *done || grid.rows >= MAX_SIDE || grid.cols >= MAX_SIDE {
                    continue;
                }
                // Turn the grid so that the side is its bottom, grow, turn back.
                let turned = match side {
                    0 => grid.clone(),
                    1 => grid.flip_rows(),
                    2 => grid.transpose(),
                    _ => grid.transpose().flip_rows(),
                };
                let (result, g) = self.grow_bottom(turned, buckets, used);
                match result {
                    Growth::Grown => grown = true,
                    Growth::Cut => {
                        cut = true;
                        *done = true;
                    }
                    Growth::Stopped => *done = true,
                }
                grid = match side {
                    0 => g,
                    1 => g.flip_rows(),
                    2 => g.transpose(),
                    _ => g.flip_rows().transpose(),
                };
            }
            if !grown {
                break;
            }
        }
        Assembled { grid, cut }
    }

    /// Adds a row below the grid's last (it has at least 3 rows), or says why not.
    fn grow_bottom(&self, grid: Grid, buckets: &Buckets, used: &mut [bool]) -> (Growth, Grid) {
        let n = grid.rows;
        let margin = (RING_RADIUS + 1) as f64;
        let (w, h) = (self.img.w as f64, self.img.h as f64);
        let mut row = Vec::with_capacity(grid.cols);
        let mut taken = Vec::new();
        let mut outcome = Growth::Grown;
        for c in 0..grid.cols {
            let (p0, p1, p2) = (grid.at(n - 3, c), grid.at(n - 2, c), grid.at(n - 1, c));
            let pred = predict(p0, p1, p2);
            if !(pred.x >= margin
                && pred.y >= margin
                && pred.x <= w - 1.0 - margin
                && pred.y <= h - 1.0 - margin)
            {
                outcome = Growth::Cut;
                break;
            }
            let across = if c + 1 < grid.cols {
                (grid.at(n - 1, c + 1) - p2).norm()
            } else {
                (grid.at(n - 1, c - 1) - p2).norm()
            };
            let radius = SEARCH_RADIUS * (p2 - p1).norm().min(across);
            if let Some(j) = self.nearest(buckets, pred, radius, used) {
                used[j] = true;
                taken.push(j);
                row.push(self.cands[j].p);
            } else if let Some(p) = self.strongest_near(pred, radius) {
                row.push(p);
            } else {
                outcome = Growth::Stopped;
                break;
            }
        }
        if matches!(outcome, Growth::Grown) {
            let mut bigger = grid.clone();
            bigger.pts.extend_from_slice(&row);
            bigger.rows += 1;
            if bigger
                .alternation(self.img, n - 2, self.min_contrast)
                .is_some()
            {
                return (Growth::Grown, bigger);
            }
            outcome = Growth::Stopped;
        }
        taken.iter().for_each(|&j| used[j] = false);
        (outcome, grid)
    }

    /// The pixel of strongest response within `radius` of `p`, if above the fill
    /// threshold.
    fn strongest_near(&self, p: V2, radius: f64) -> Option<V2> {
        let r = self.response;
        let x0 = (p.x - radius).floor().max(0.0) as usize;
        let y0 = (p.y - radius).floor().max(0.0) as usize;
        let x1 = ((p.x + radius).ceil().max(0.0) as usize).min(r.w.saturating_sub(1));
        let y1 = ((p.y + radius).ceil().max(0.0) as usize).min(r.h.saturating_sub(1));
        let mut best: Option<(f32, V2)> = None;
        for y in y0..=y1 {
            for x in x0..=x1 {
                let q = V2::new(x as f64, y as f64);
                if (q - p).norm_squared() > radius * radius {
                    continue;
                }
                let v = r.at(x, y);
                if v > self.fill_threshold && best.is_none_or(|(b, _)| v > b) {
                    best = Some((v, q));
                }
            }
        }
        best.map(|(_, q)| q)
    }
}

/// The next corner of a line after `p0, p1, p2`: the last step turned and scaled as the
/// step before it was (clamped, for perspective and lens curvature).
fn predict(p0: V2, p1: V2, p2: V2) -> V2 {
    let v1 = p1 - p0;
    let v2 = p2 - p1;
    let (n1, n2) = (v1.norm(), v2.norm());
    if n1 < 1e-9 || n2 < 1e-9 {
        return p2 + v2;
    }
    let ratio = (n2 / n1).clamp(0.7, 1.4);
    let turn = (v1.x * v2.y - v1.y * v2.x)
        .atan2(v1.dot(&v2))
        .clamp(-0.35, 0.35);
    let (s, c) = turn.sin_cos();
    let v3 = V2::new(c * v2.x - s * v2.y, s * v2.x + c * v2.y) * ratio;
    p2 + v3
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(rows: usize, cols: usize) -> Grid {
        let pts = (0..rows)
            .flat_map(|r| (0..cols).map(move |c| V2::new(c as f64, r as f64 * 10.0)))
            .collect();
        Grid { rows, cols, pts }
    }

    #[test]
    fn turning_grids() {
        let g = grid(2, 3);
        let t = g.transpose();
        assert_eq!((t.rows, t.cols), (3, 2));
        assert_eq!(t.at(2, 1), g.at(1, 2));
        assert_eq!(g.flip_rows().at(0, 0), g.at(1, 0));
        assert_eq!(g.flip_cols().at(0, 0), g.at(0, 2));
        assert_eq!(g.transpose().transpose(), g);
    }

    #[test]
    fn prediction_continues_lines() {
        let p = predict(V2::new(0.0, 0.0), V2::new(10.0, 0.0), V2::new(20.0, 0.0));
        assert!((p - V2::new(30.0, 0.0)).norm() < 1e-9);
        let p = predict(V2::new(0.0, 0.0), V2::new(10.0, 0.0), V2::new(18.0, 0.0));
        assert!((p - V2::new(24.4, 0.0)).norm() < 1e-9);
    }
}
