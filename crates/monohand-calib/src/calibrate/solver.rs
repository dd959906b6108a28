//! Levenberg-Marquardt over a rig's intrinsics, camera poses and board poses, with the
//! normal equations' block-arrowhead structure solved by a Schur complement.
//!
//! The unknowns are split in two: the *global* ones (each camera's 12 intrinsics, each
//! camera's pose relative to the first, 6 each for cameras after the first), some of which
//! may be held fixed, and one board pose (6) per *block* (a view of a single camera, or an
//! instant of a rig). A corner's residual involves the globals of its camera and its
//! block's board pose only, so `J^T J` is an arrowhead: a dense global block, 6x6 blocks on
//! the diagonal and their couplings to the globals. The board poses are eliminated per
//! block and only the Schur complement over the free globals is factored.
//!
//! Conventions follow the hand solver (`monohand_core::fitting::lm`): Marquardt damping
//! `lambda * max(diag(H), 1e-9 max diag)`, Nielsen's update of lambda from the gain ratio,
//! a step accepted only if it lowers the cost.

use super::projection::{corner_pixel, project_corner, Intr, Pose, N_INTR};
use monohand_core::camera::LensModel;
use nalgebra::{DMatrix, DVector, Matrix6, Point2, Vector2, Vector3, Vector6};

/// Relative cost decrease below which the solve has converged.
const COST_TOLERANCE: f64 = 1e-10;
/// Relative step length below which the solve has converged.
const STEP_TOLERANCE: f64 = 1e-12;
/// Initial damping.
const INITIAL_DAMPING: f64 = 1e-3;

/// One camera's corners of a block: (camera, corners in object order).
pub(crate) type Observation<'a> = (usize, &'a [Point2<f64>]);

/// The observations: for each block, the cameras that saw the board and their corners.
pub(crate) struct Problem<'a> {
    /// The board's corners, mm.
    pub object: &'a [Vector3<f64>],
    /// Per block: (camera, its corners in object order).
    pub blocks: Vec<Vec<Observation<'a>>>,
    /// Number of cameras.
    pub n_cameras: usize,
    /// The lens model of every camera (what their intrinsics' coefficients distort).
    pub lens: LensModel,
}

impl Problem<'_> {
    /// Number of global unknowns (fixed ones included).
    pub fn n_global(&self) -> usize {
        N_INTR * self.n_cameras + 6 * self.n_cameras.saturating_sub(1)
    }

    /// Global index of camera `k`'s relative pose's `j`-th increment (`k >= 1`).
    fn rel_index(&self, k: usize, j: usize) -> usize {
        N_INTR * self.n_cameras + 6 * (k - 1) + j
    }

    /// Number of corners observed.
    pub fn n_corners(&self) -> usize {
        self.blocks.iter().flatten().map(|(_, c)| c.len()).sum()
    }
}

/// The unknowns.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct State {
    /// Each camera's intrinsics.
    pub intr: Vec<Intr>,
    /// Each camera's pose from the first camera (`rel[0]` is the identity, never moved).
    pub rel: Vec<Pose>,
    /// The board's pose in the first camera, per block.
    pub boards: Vec<Pose>,
}

/// The outcome of a solve.
pub(crate) struct Solved {
    /// The estimate.
    pub state: State,
    /// Sum of squared residuals, px^2.
    pub sse: f64,
    /// `(J^T J)^-1` restricted to the free globals (in [`Solved::free`] order), if the
    /// normal equations were invertible.
    pub cov: Option<DMatrix<f64>>,
    /// Global index of each free global.
    pub free: Vec<usize>,
    /// Number of free unknowns (free globals and board poses).
    pub n_params: usize,
}

/// The normal equations `J^T J`, `J^T r` in arrowhead form.
struct Normal {
    u: DMatrix<f64>,
    g: DVector<f64>,
    w: Vec<DMatrix<f64>>,
    v: Vec<Matrix6<f64>>,
    gb: Vec<Vector6<f64>>,
}

impl Normal {
    fn new(nf: usize, nb: usize) -> Normal {
        Normal {
            u: DMatrix::zeros(nf, nf),
            g: DVector::zeros(nf),
            w: vec![DMatrix::zeros(nf, 6); nb],
            v: vec![Matrix6::zeros(); nb],
            gb: vec![Vector6::zeros(); nb],
        }
    }
}

/// The sum of squared residuals, `None` if a corner cannot be projected.
pub(crate) fn cost(pb: &Problem, s: &State) -> Option<f64> {
    let mut sse = 0.0;
    for (b, obs) in pb.blocks.iter().enumerate() {
        for &(k, corners) in obs {
            for (x, c) in pb.object.iter().zip(corners) {
                let px = corner_pixel(pb.lens, &s.intr[k], &s.rel[k], &s.boards[b], x)?;
                sse += (px - c.coords).norm_squared();
            }
        }
    }
    sse.is_finite().then_some(sse)
}

/// Sum of squared residuals and corner count per block and observation, in `pb.blocks`'
/// order (`None` where a corner cannot be projected).
pub(crate) fn errors(pb: &Problem, s: &State) -> Vec<Vec<Option<(f64, usize)>>> {
    pb.blocks
        .iter()
        .enumerate()
        .map(|(b, obs)| {
            obs.iter()
                .map(|&(k, corners)| {
                    let mut sse = 0.0;
                    for (x, c) in pb.object.iter().zip(corners) {
                        let px = corner_pixel(pb.lens, &s.intr[k], &s.rel[k], &s.boards[b], x)?;
                        sse += (px - c.coords).norm_squared();
                    }
                    Some((sse, corners.len()))
                })
                .collect()
        })
        .collect()
}

/// Fills the normal equations at `s`; returns the sum of squared residuals.
fn linearise(pb: &Problem, s: &State, map: &[Option<usize>], n: &mut Normal) -> Option<f64> {
    n.u.fill(0.0);
    n.g.fill(0.0);
    let mut sse = 0.0;
    let mut cols: Vec<(usize, Vector2<f64>)> = Vec::with_capacity(N_INTR + 6);
    for (b, obs) in pb.blocks.iter().enumerate() {
        let (w, v, gb) = (&mut n.w[b], &mut n.v[b], &mut n.gb[b]);
        w.fill(0.0);
        *v = Matrix6::zeros();
        *gb = Vector6::zeros();
        for &(k, corners) in obs {
            for (x, c) in pb.object.iter().zip(corners) {
                let p = project_corner(pb.lens, &s.intr[k], &s.rel[k], &s.boards[b], x)?;
                let e = p.px - c.coords;
                sse += e.norm_squared();
                cols.clear();
                for j in 0..N_INTR {
                    if let Some(i) = map[N_INTR * k + j] {
                        cols.push((i, p.d_intr.column(j).into_owned()));
                    }
                }
                if k > 0 {
                    for j in 0..6 {
                        if let Some(i) = map[pb.rel_index(k, j)] {
                            cols.push((i, p.d_rel.column(j).into_owned()));
                        }
                    }
                }
                let jb = &p.d_board;
                *v += jb.transpose() * jb;
                *gb += jb.transpose() * e;
                for (a, &(ia, ca)) in cols.iter().enumerate() {
                    n.g[ia] += ca.dot(&e);
                    let wa = ca.transpose() * jb;
                    for q in 0..6 {
                        w[(ia, q)] += wa[q];
                    }
                    for &(ib, cb) in &cols[..=a] {
                        n.u[(ia, ib)] += ca.dot(&cb);
                    }
                }
            }
        }
    }
    // Only one triangle was accumulated (in the order of `cols`, which is increasing).
    let nf = n.u.nrows();
    for i in 0..nf {
        for j in 0..i {
            n.u[(j, i)] = n.u[(i, j)];
        }
    }
    sse.is_finite().then_some(sse)
}

/// Solves the damped normal equations by the Schur complement over the free globals.
/// Returns the globals' step and each block's.
fn damped_step(n: &Normal, lambda: f64) -> Option<(DVector<f64>, Vec<Vector6<f64>>)> {
    let nf = n.u.nrows();
    let max_diag = (0..nf)
        .map(|i| n.u[(i, i)])
        .chain(n.v.iter().flat_map(|v| (0..6).map(move |i| v[(i, i)])))
        .fold(0.0f64, f64::max)
        .max(1e-12);
    let damp = |d: f64| lambda * d.max(1e-9 * max_diag);
    let mut s = n.u.clone();
    for i in 0..nf {
        s[(i, i)] += damp(n.u[(i, i)]);
    }
    let mut r = -&n.g;
    let mut vinv = Vec::with_capacity(n.v.len());
    let mut wv = DMatrix::<f64>::zeros(nf, 6);
    for ((w, v), gb) in n.w.iter().zip(&n.v).zip(&n.gb) {
        let mut vd = *v;
        for i in 0..6 {
            vd[(i, i)] += damp(v[(i, i)]);
        }
        let vi = vd.cholesky()?.inverse();
        w.mul_to(&vi, &mut wv);
        s.gemm(-1.0, &wv, &w.transpose(), 1.0);
        r.gemv(1.0, &wv, gb, 1.0);
        vinv.push(vi);
    }
    let dg = solve_scaled(&s, &r)?;
    let db =
        n.w.iter()
            .zip(&n.gb)
            .zip(&vinv)
            .map(|((w, gb), vi)| vi * (-gb - w.tr_mul(&dg).fixed_rows::<6>(0)))
            .collect();
    Some((dg, db))
}

/// Solves `s x = r` for a symmetric positive definite `s`, Jacobi-scaled for conditioning.
fn solve_scaled(s: &DMatrix<f64>, r: &DVector<f64>) -> Option<DVector<f64>> {
    let d = jacobi(s)?;
    let ss = DMatrix::from_fn(s.nrows(), s.ncols(), |i, j| s[(i, j)] * d[i] * d[j]);
    let rr = r.component_mul(&d);
    Some(ss.cholesky()?.solve(&rr).component_mul(&d))
}

/// `1 / sqrt(diag(s))`, `None` if a diagonal entry is not positive.
fn jacobi(s: &DMatrix<f64>) -> Option<DVector<f64>> {
    let d = DVector::from_fn(s.nrows(), |i, _| 1.0 / s[(i, i)].sqrt());
    d.iter().all(|v| v.is_finite() && *v > 0.0).then_some(d)
}

/// The inverse of the Schur complement at `lambda = 0`: the globals' block of
/// `(J^T J)^-1`.
fn global_covariance(n: &Normal) -> Option<DMatrix<f64>> {
    let nf = n.u.nrows();
    let mut s = n.u.clone();
    for (w, v) in n.w.iter().zip(&n.v) {
        let vi = v.cholesky()?.inverse();
        s -= w * vi * w.transpose();
    }
    let d = jacobi(&s)?;
    let ss = DMatrix::from_fn(nf, nf, |i, j| s[(i, j)] * d[i] * d[j]);
    let inv = ss.cholesky()?.inverse();
    Some(DMatrix::from_fn(nf, nf, |i, j| inv[(i, j)] * d[i] * d[j]))
}

/// `s` moved by the step.
fn apply(pb: &Problem, s: &State, free: &[usize], dg: &DVector<f64>, db: &[Vector6<f64>]) -> State {
    let mut out = s.clone();
    let mut rel_d = vec![[0.0; 6]; pb.n_cameras];
    for (&gi, &d) in free.iter().zip(dg.iter()) {
        if gi < N_INTR * pb.n_cameras {
            out.intr[gi / N_INTR][gi % N_INTR] += d;
        } else {
            let r = gi - N_INTR * pb.n_cameras;
            rel_d[1 + r / 6][r % 6] = d;
        }
    }
    for ((o, r), d) in out.rel.iter_mut().zip(&s.rel).zip(&rel_d).skip(1) {
        *o = r.retract(d);
    }
    for (b, d) in db.iter().enumerate() {
        out.boards[b] = s.boards[b].retract(d.as_slice());
    }
    out
}

/// Predicted decrease of the cost for the step: `-(2 g.d + d^T H d)`.
fn predicted_decrease(n: &Normal, dg: &DVector<f64>, db: &[Vector6<f64>]) -> f64 {
    let mut lin = n.g.dot(dg);
    let mut quad = dg.dot(&(&n.u * dg));
    for (((w, v), gb), d) in n.w.iter().zip(&n.v).zip(&n.gb).zip(db) {
        lin += gb.dot(d);
        quad += 2.0 * dg.dot(&(w * d)) + d.dot(&(v * d));
    }
    -(2.0 * lin + quad)
}

/// Size of the unknowns, for the relative step test.
fn state_norm(s: &State) -> f64 {
    let intr: f64 = s.intr.iter().flatten().map(|v| v * v).sum();
    let poses: f64 = s
        .rel
        .iter()
        .chain(&s.boards)
        .map(|p| p.t.norm_squared() + p.r.scaled_axis().norm_squared())
        .sum();
    (intr + poses).sqrt()
}

/// Minimises the sum of squared reprojection errors from `start`; `free_global[i]` says
/// whether global `i` moves. `None` if the start cannot be evaluated.
pub(crate) fn solve(
    pb: &Problem,
    start: State,
    free_global: &[bool],
    max_iterations: usize,
) -> Option<Solved> {
    let free: Vec<usize> = (0..pb.n_global())
        .filter(|&i| free_global.get(i) == Some(&true))
        .collect();
    let mut map = vec![None; pb.n_global()];
    for (c, &i) in free.iter().enumerate() {
        map[i] = Some(c);
    }
    let mut n = Normal::new(free.len(), pb.blocks.len());
    let mut state = start;
    let mut sse = linearise(pb, &state, &map, &mut n)?;
    let mut lambda = INITIAL_DAMPING;
    let mut nu = 2.0;
    let mut iterations = 0;
    while iterations < max_iterations && sse > 1e-24 {
        iterations += 1;
        let Some((dg, db)) = damped_step(&n, lambda) else {
            lambda *= nu;
            nu *= 2.0;
            if lambda > 1e16 {
                break;
            }
            continue;
        };
        let step = (dg.norm_squared() + db.iter().map(|d| d.norm_squared()).sum::<f64>()).sqrt();
        let small_step = step <= STEP_TOLERANCE * (state_norm(&state) + STEP_TOLERANCE);
        let candidate = apply(pb, &state, &free, &dg, &db);
        match cost(pb, &candidate) {
            Some(nc) if nc < sse => {
                let predicted = predicted_decrease(&n, &dg, &db);
                let rho = if predicted > 0.0 {
                    (sse - nc) / predicted
                } else {
                    1.0
                };
                let small_decrease = sse - nc <= COST_TOLERANCE * sse;
                lambda *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                lambda = lambda.max(1e-15);
                nu = 2.0;
                state = candidate;
                sse = linearise(pb, &state, &map, &mut n)?;
                if small_decrease || small_step {
                    break;
                }
            }
            _ => {
                if small_step {
                    break;
                }
                lambda *= nu;
                nu *= 2.0;
                if lambda > 1e16 {
                    break;
                }
            }
        }
    }
    let n_params = free.len() + 6 * pb.blocks.len();
    Some(Solved {
        cov: global_covariance(&n),
        state,
        sse,
        free,
        n_params,
    })
}
