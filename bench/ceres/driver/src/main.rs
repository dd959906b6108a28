//! Driver of the monohand vs Ceres Solver benchmark (`bench/ceres/run.sh`).
//!
//! 1. Builds the problems: the 1,500 STB B1Counting hands projected with the
//!    left STB camera, Gaussian pixel noise of 0 and 3 px (fixed seed), fitted
//!    with the skeleton `fit_skeleton` estimates for the subject.
//! 2. Solves them with monohand and times it:
//!    - *scratch*: the starts our from-scratch fit iterates from
//!      (`HandFitter::starting_poses`), one LM run from each (cap
//!      `max_iterations`), best kept; and, separately, the whole `fit`
//!      (initialisation + LM + second finger-seating pass);
//!    - *warm*: frame i starts from the previous frame's solution, the same
//!      for both solvers: our whole from-scratch `fit` of frame i - 1 (not a
//!      chain of warm solutions, which could drift into a wrong local minimum
//!      and make the problems depend on the solver); one LM run with cap
//!      `max_iterations_tracking`.
//! 3. Writes the same problems and starts for `ceres_fit`, runs it, reads its
//!    solutions and prints the comparison (Markdown) to stdout and
//!    `OUT/report.md`; per-problem numbers go to `OUT/per_problem.tsv`.
//!
//! Usage: `monohand-ceres-bench --data DIR --ceres BIN --out DIR
//! [--repeats N] [--frames N] [--seed S] [--linear-solver cholesky|qr]`

use monohand_core::hand_model::{fit_skeleton, NUM_PARAMS};
use monohand_core::prelude::*;
use nalgebra::{UnitQuaternion, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::error::Error;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

type Res<T> = Result<T, Box<dyn Error>>;

const NOISES: [f64; 2] = [0.0, 3.0];

struct Args {
    data: PathBuf,
    ceres: PathBuf,
    out: PathBuf,
    repeats: usize,
    frames: Option<usize>,
    seed: u64,
    linear_solver: String,
}

fn parse_args() -> Res<Args> {
    let mut a = Args {
        data: PathBuf::new(),
        ceres: PathBuf::new(),
        out: PathBuf::new(),
        repeats: 3,
        frames: None,
        seed: 2018,
        linear_solver: "cholesky".into(),
    };
    let mut it = std::env::args().skip(1);
    while let Some(k) = it.next() {
        let mut v = || it.next().ok_or_else(|| format!("{k} needs a value"));
        match k.as_str() {
            "--data" => a.data = v()?.into(),
            "--ceres" => a.ceres = v()?.into(),
            "--out" => a.out = v()?.into(),
            "--repeats" => a.repeats = v()?.parse::<usize>()?.max(1),
            "--frames" => a.frames = Some(v()?.parse()?),
            "--seed" => a.seed = v()?.parse()?,
            "--linear-solver" => a.linear_solver = v()?,
            _ => return Err(format!("unknown argument {k}").into()),
        }
    }
    if a.data.as_os_str().is_empty()
        || a.ceres.as_os_str().is_empty()
        || a.out.as_os_str().is_empty()
    {
        return Err("usage: --data DIR --ceres BIN --out DIR [--repeats N] [--frames N] [--seed S] [--linear-solver cholesky|qr]".into());
    }
    Ok(a)
}

/// One fitting problem: a frame's keypoints and the starts to iterate from.
struct Problem {
    frame: usize,
    keypoints: Keypoints2d,
    starts: Vec<HandPose>,
}

/// One solver's answer to one problem.
#[derive(Clone, Copy)]
struct Outcome {
    /// Minimum over the repeats, nanoseconds, all starts together.
    time_ns: f64,
    /// Iterations, summed over the starts.
    iterations: usize,
    /// Best pose over the starts.
    pose: HandPose,
}

struct Case {
    name: String,
    noise: f64,
    warm: bool,
    max_iter: usize,
    problems: Vec<Problem>,
    ours_lm: Vec<Outcome>,
    /// Scratch cases only: the whole `HandFitter::fit`.
    ours_full: Vec<Outcome>,
    ceres: Vec<Outcome>,
    /// Ceres' own minimizer time (excludes its per-solve preprocessing).
    ceres_minimizer_ns: Vec<f64>,
}

/// Projects joints into the camera with Gaussian pixel noise, as the core's STB test does.
fn project(
    cam: &Camera,
    joints: &[Vector3<f64>; NUM_JOINTS],
    noise: f64,
    rng: &mut StdRng,
) -> Res<Keypoints2d> {
    let n = Normal::new(0.0, noise.max(1e-12))?;
    let mut kp = Keypoints2d::default();
    for (j, x) in joints.iter().enumerate() {
        let px = cam.project(x).ok_or("a label is behind the camera")?;
        let (du, dv) = if noise > 0.0 {
            (n.sample(rng), n.sample(rng))
        } else {
            (0.0, 0.0)
        };
        kp.points[j] = [px.x + du, px.y + dv, 1.0];
    }
    Ok(kp)
}

/// Residual weight of a keypoint, as `HandFitter` computes it.
fn weight(p: f64, o: &FitOptions) -> f64 {
    if p > 0.0 && p >= o.cost.min_confidence {
        p.powf(o.cost.confidence_power)
    } else {
        0.0
    }
}

/// monohand's cost (sum of squared weighted pixel residuals) of a pose; the camera has no distortion.
fn cost(sk: &HandSkeleton, cam: &Camera, kp: &Keypoints2d, pose: &HandPose, o: &FitOptions) -> f64 {
    let x = forward_kinematics(sk, pose);
    let mut c = 0.0;
    for (j, p) in kp.points.iter().enumerate() {
        let w = weight(p[2], o);
        if w > 0.0 {
            let q = cam
                .project(&x[j])
                .map(|q| (q.x, q.y))
                .unwrap_or((f64::INFINITY, f64::INFINITY));
            c += (w * (q.0 - p[0])).powi(2) + (w * (q.1 - p[1])).powi(2);
        }
    }
    c
}

/// monohand reports its cost with the keypoint residuals in milliradians (`px 1000 / f`);
/// in px² for the comparison (this driver's cost and Ceres' are in pixels). Needs one focal
/// length for both axes, as the STB camera has.
fn px2_from_mrad2(cost: f64, cam: &Camera) -> Res<f64> {
    let k = &cam.intrinsics;
    if (k.fx - k.fy).abs() > 1e-9 * k.fx {
        return Err(format!(
            "fx {} and fy {} differ: costs in px² are not comparable",
            k.fx, k.fy
        )
        .into());
    }
    Ok(cost * (k.fx / 1000.0).powi(2))
}

fn mean_error(sk: &HandSkeleton, pose: &HandPose, truth: &[Vector3<f64>; NUM_JOINTS]) -> f64 {
    let x = forward_kinematics(sk, pose);
    x.iter()
        .zip(truth)
        .map(|(a, b)| (a - b).norm())
        .sum::<f64>()
        / NUM_JOINTS as f64
}

/// Times `f` `repeats` times; returns the fastest time (ns) and the last result.
fn timed<T>(repeats: usize, mut f: impl FnMut() -> Res<T>) -> Res<(f64, T)> {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..repeats {
        let t0 = Instant::now();
        let r = f()?;
        best = best.min(t0.elapsed().as_nanos() as f64);
        out = Some(r);
    }
    Ok((best, out.ok_or("no repeat")?))
}

fn in_front(sk: &HandSkeleton, p: &HandPose) -> bool {
    forward_kinematics(sk, p).iter().all(|x| x.z > 1.0)
}

fn params_line(p: &HandPose) -> String {
    p.to_params()
        .iter()
        .map(|v| format!("{v:e}"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn main() {
    if let Err(e) = run() {
        eprintln!("monohand-ceres-bench: {e}");
        std::process::exit(1);
    }
}

fn run() -> Res<()> {
    let args = parse_args()?;
    std::fs::create_dir_all(&args.out)?;
    let seq = monohand_eval::stb::StbSequence::load(args.data.join("labels/B1Counting_BB.mat"))?;
    let (cam, _) = monohand_eval::stb::stb_cameras(args.data.join("camera_params.json"))?;
    let all: Vec<_> = seq.frames.iter().map(|f| f.joints).collect();
    let fit = fit_skeleton(&all, &HandSkeleton::default_for(HandSide::Left))?;
    let sk = fit.skeleton;
    let n = args.frames.unwrap_or(all.len()).min(all.len());
    let truth = &all[..n];
    eprintln!(
        "{n} STB frames; subject skeleton residual {:.3} mm; {} repeats per solve",
        fit.residual_mm, args.repeats
    );
    let opts = FitOptions::default();
    let mut cases = Vec::new();
    for (ni, &noise) in NOISES.iter().enumerate() {
        let mut rng = StdRng::seed_from_u64(args.seed + ni as u64);
        let kps = truth
            .iter()
            .map(|j| project(&cam, j, noise, &mut rng))
            .collect::<Res<Vec<_>>>()?;
        let scratch = scratch_case(&args, &cam, sk, &kps, noise, &opts)?;
        let warm = warm_case(&args, &cam, sk, &kps, noise, &opts, &scratch)?;
        eprintln!("noise {noise} px: our solves done");
        cases.push(scratch);
        cases.push(warm);
    }
    let problems_path = args.out.join("problems.txt");
    std::fs::write(
        &problems_path,
        problems_text(&cam, &sk, &cases, &opts, args.seed)?,
    )?;
    run_ceres(&args, &problems_path, &mut cases, &cam, &sk, &opts)?;
    let report = report(&args, &cases, &sk, &cam, truth, &opts, fit.residual_mm)?;
    print!("{report}");
    std::fs::write(args.out.join("report.md"), &report)?;
    let tsv = per_problem_tsv(&cases, &cam, &sk, truth, &opts)?;
    std::fs::write(args.out.join("per_problem.tsv"), tsv)?;
    Ok(())
}

/// An empty case of the problems of noise level `noise`.
fn case(name: &str, noise: f64, warm: bool, max_iter: usize) -> Case {
    Case {
        name: format!("noise{noise}px-{name}"),
        noise,
        warm,
        max_iter,
        problems: Vec::new(),
        ours_lm: Vec::new(),
        ours_full: Vec::new(),
        ceres: Vec::new(),
        ceres_minimizer_ns: Vec::new(),
    }
}

/// Every frame from scratch: our LM from each start (the LM part alone, with the scratch
/// iteration cap), and our full fit.
fn scratch_case(
    args: &Args,
    cam: &Camera,
    sk: HandSkeleton,
    kps: &[Keypoints2d],
    noise: f64,
    opts: &FitOptions,
) -> Res<Case> {
    let mut fitter = HandFitter::new(sk, *opts)?;
    let mut lm_scratch = HandFitter::new(
        sk,
        FitOptions {
            solver: SolverSettings {
                max_iterations_tracking: opts.solver.max_iterations,
                ..opts.solver
            },
            ..*opts
        },
    )?;
    let mut scratch = case("scratch", noise, false, opts.solver.max_iterations);
    for (i, kp) in kps.iter().enumerate() {
        let views = [View::new(cam, kp)];
        let starts = fitter.starting_poses(&views)?;
        if starts.is_empty() || !starts.iter().all(|s| in_front(&sk, s)) {
            return Err(format!("frame {i}: no usable start").into());
        }
        let (t, (iters, pose, c)) = timed(args.repeats, || {
            let mut best: Option<FitResult> = None;
            let mut iters = 0;
            for s in &starts {
                let r = lm_scratch.fit_from(&views, s)?;
                iters += r.iterations;
                if best.is_none_or(|b| r.cost < b.cost) {
                    best = Some(r);
                }
            }
            let b = best.ok_or("no start")?;
            Ok((iters, b.pose, b.cost))
        })?;
        check_cost(px2_from_mrad2(c, cam)?, cost(&sk, cam, kp, &pose, opts))?;
        scratch.ours_lm.push(Outcome {
            time_ns: t,
            iterations: iters,
            pose,
        });
        let (t, full) = timed(args.repeats, || Ok(fitter.fit(&views)?))?;
        scratch.ours_full.push(Outcome {
            time_ns: t,
            iterations: full.iterations,
            pose: full.pose,
        });
        scratch.problems.push(Problem {
            frame: i,
            keypoints: *kp,
            starts,
        });
    }
    Ok(scratch)
}

/// Every frame but the first warm-started from the previous frame's solution (our full
/// fit, in `scratch`).
fn warm_case(
    args: &Args,
    cam: &Camera,
    sk: HandSkeleton,
    kps: &[Keypoints2d],
    noise: f64,
    opts: &FitOptions,
    scratch: &Case,
) -> Res<Case> {
    let mut lm_warm = HandFitter::new(sk, *opts)?;
    let mut warm = case("warm", noise, true, opts.solver.max_iterations_tracking);
    for (i, kp) in kps.iter().enumerate().skip(1) {
        let prev = scratch.ours_full[i - 1].pose;
        let views = [View::new(cam, kp)];
        if !in_front(&sk, &prev) {
            return Err(format!("frame {i}: previous solution not in front of the camera").into());
        }
        let (t, r) = timed(args.repeats, || Ok(lm_warm.fit_from(&views, &prev)?))?;
        check_cost(
            px2_from_mrad2(r.cost, cam)?,
            cost(&sk, cam, kp, &r.pose, opts),
        )?;
        warm.ours_lm.push(Outcome {
            time_ns: t,
            iterations: r.iterations,
            pose: r.pose,
        });
        warm.problems.push(Problem {
            frame: i,
            keypoints: *kp,
            starts: vec![prev],
        });
    }
    Ok(warm)
}

/// The problems file the C++ Ceres program reads: the camera, the skeleton, poses on
/// which its forward kinematics must match ours, then every case's problems.
fn problems_text(
    cam: &Camera,
    sk: &HandSkeleton,
    cases: &[Case],
    opts: &FitOptions,
    seed: u64,
) -> Res<String> {
    let mut s = String::new();
    writeln!(s, "monohand-ceres-problems 1")?;
    let k = &cam.intrinsics;
    writeln!(s, "camera {:e} {:e} {:e} {:e}", k.fx, k.fy, k.cx, k.cy)?;
    for g in &sk.fingers {
        let v = [
            g.base,
            g.rest_direction.into_inner(),
            g.flexion_axis.into_inner(),
            g.abduction_axis.into_inner(),
            Vector3::from(g.lengths),
        ];
        let nums: Vec<String> = v
            .iter()
            .flat_map(|x| x.iter().map(|c| format!("{c:e}")))
            .collect();
        writeln!(s, "finger {}", nums.join(" "))?;
    }
    let join = |a: &[f64]| {
        a.iter()
            .map(|v| format!("{v:e}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    writeln!(s, "lower {}", join(&sk.limits.lower))?;
    writeln!(s, "upper {}", join(&sk.limits.upper))?;
    let mut checks = random_poses(sk, seed ^ 0xf00d);
    checks.extend(cases[0].ours_lm.iter().take(10).map(|o| o.pose));
    writeln!(s, "fkcheck {}", checks.len())?;
    for p in &checks {
        let j = forward_kinematics(sk, p);
        let nums: Vec<String> = j
            .iter()
            .flat_map(|x| x.iter().map(|c| format!("{c:e}")))
            .collect();
        writeln!(s, "{} {}", params_line(p), nums.join(" "))?;
    }
    for c in cases {
        writeln!(s, "case {} {} {}", c.name, c.max_iter, c.problems.len())?;
        for p in &c.problems {
            writeln!(s, "problem {} {}", p.frame, p.starts.len())?;
            let obs: Vec<String> = p
                .keypoints
                .points
                .iter()
                .map(|q| format!("{:e} {:e} {:e}", q[0], q[1], weight(q[2], opts)))
                .collect();
            writeln!(s, "{}", obs.join(" "))?;
            for st in &p.starts {
                writeln!(s, "{}", params_line(st))?;
            }
        }
    }
    writeln!(s, "end")?;
    Ok(s)
}

/// 30 random poses within the limits, in front of the camera.
fn random_poses(sk: &HandSkeleton, seed: u64) -> Vec<HandPose> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..30)
        .map(|_| {
            let l = &sk.limits;
            HandPose {
                translation: Vector3::new(
                    rng.random_range(-100.0..100.0),
                    rng.random_range(-100.0..100.0),
                    rng.random_range(300.0..800.0),
                ),
                rotation: UnitQuaternion::from_euler_angles(
                    rng.random_range(-3.0..3.0),
                    rng.random_range(-1.5..1.5),
                    rng.random_range(-3.0..3.0),
                ),
                angles: std::array::from_fn(|i| rng.random_range(l.lower[i]..=l.upper[i])),
            }
        })
        .collect()
}

/// Runs the Ceres program on the problems file and reads its solutions into `cases`,
/// checking each reported cost against ours.
fn run_ceres(
    args: &Args,
    problems_path: &std::path::Path,
    cases: &mut [Case],
    cam: &Camera,
    sk: &HandSkeleton,
    opts: &FitOptions,
) -> Res<()> {
    let ceres_out = args.out.join("ceres_results.txt");
    eprintln!("running {}", args.ceres.display());
    let status = std::process::Command::new(&args.ceres)
        .arg(problems_path)
        .arg(&ceres_out)
        .args(["--repeats", &args.repeats.to_string()])
        .args(["--linear-solver", &args.linear_solver])
        .status()?;
    if !status.success() {
        return Err(format!("{} failed: {status}", args.ceres.display()).into());
    }
    let text = std::fs::read_to_string(&ceres_out)?;
    let mut lines = text.lines();
    for c in cases.iter_mut() {
        for p in &c.problems {
            let line = lines.next().ok_or("ceres results too short")?;
            let f: Vec<&str> = line.split_whitespace().collect();
            if f.len() != 7 + NUM_PARAMS || f[0] != c.name || f[1].parse::<usize>()? != p.frame {
                return Err(format!(
                    "unexpected ceres result line for {} frame {}: {line}",
                    c.name, p.frame
                )
                .into());
            }
            let mut params = [0.0; NUM_PARAMS];
            for (i, v) in params.iter_mut().enumerate() {
                *v = f[7 + i].parse()?;
            }
            let pose = HandPose::from_params(&params).ok_or_else(|| {
                format!("{} frame {}: Ceres failed on every start", c.name, p.frame)
            })?;
            let reported: f64 = f[6].parse()?;
            check_cost(reported, cost(sk, cam, &p.keypoints, &pose, opts))?;
            c.ceres.push(Outcome {
                time_ns: f[3].parse()?,
                iterations: f[5].parse()?,
                pose,
            });
            c.ceres_minimizer_ns.push(f[4].parse()?);
        }
    }
    Ok(())
}

/// One row per problem: ours and Ceres's time, iterations, cost and error.
fn per_problem_tsv(
    cases: &[Case],
    cam: &Camera,
    sk: &HandSkeleton,
    truth: &[[Vector3<f64>; NUM_JOINTS]],
    opts: &FitOptions,
) -> Res<String> {
    let mut tsv = String::from(
        "case\tframe\tstarts\tours_us\tours_iters\tours_cost\tours_err_mm\tceres_us\tceres_iters\tceres_cost\tceres_err_mm\tfull_us\tfull_cost\tfull_err_mm\n",
    );
    for c in cases {
        for (i, p) in c.problems.iter().enumerate() {
            let t = &truth[p.frame];
            let (o, e) = (&c.ours_lm[i], &c.ceres[i]);
            write!(
                tsv,
                "{}\t{}\t{}\t{:.2}\t{}\t{:.9e}\t{:.4}\t{:.2}\t{}\t{:.9e}\t{:.4}",
                c.name,
                p.frame,
                p.starts.len(),
                o.time_ns / 1e3,
                o.iterations,
                cost(sk, cam, &p.keypoints, &o.pose, opts),
                mean_error(sk, &o.pose, t),
                e.time_ns / 1e3,
                e.iterations,
                cost(sk, cam, &p.keypoints, &e.pose, opts),
                mean_error(sk, &e.pose, t),
            )?;
            match c.ours_full.get(i) {
                Some(f) => writeln!(
                    tsv,
                    "\t{:.2}\t{:.9e}\t{:.4}",
                    f.time_ns / 1e3,
                    cost(sk, cam, &p.keypoints, &f.pose, opts),
                    mean_error(sk, &f.pose, t)
                )?,
                None => writeln!(tsv, "\t\t\t")?,
            }
        }
    }
    Ok(tsv)
}

/// The cost a solver reports must be the cost we recompute from its pose.
fn check_cost(reported: f64, recomputed: f64) -> Res<()> {
    if (reported - recomputed).abs() > 1e-7 * recomputed.max(1e-6) {
        return Err(format!("cost mismatch: reported {reported}, recomputed {recomputed}").into());
    }
    Ok(())
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Relative slack when asking whether our cost is the same or lower than Ceres'.
const COST_RTOL: f64 = 1e-6;
/// Absolute slack (px^2) for costs that are both near zero.
const COST_ATOL: f64 = 1e-9;

#[allow(clippy::too_many_arguments)]
fn report(
    args: &Args,
    cases: &[Case],
    sk: &HandSkeleton,
    cam: &Camera,
    truth: &[[Vector3<f64>; NUM_JOINTS]],
    opts: &FitOptions,
    skeleton_residual: f64,
) -> Res<String> {
    let mut s = String::new();
    writeln!(
        s,
        "STB B1Counting, {} frames, left camera, skeleton fitted to the subject (residual {:.3} mm); \
         times are the fastest of {} runs of each solve, single-threaded; Ceres linear solver: {}.\n",
        truth.len(),
        skeleton_residual,
        args.repeats,
        args.linear_solver
    )?;
    writeln!(
        s,
        "| case | solves | median time ours (µs) | median time Ceres (µs) | speed ratio | median iterations ours / Ceres | median cost ours / Ceres (px²) | mean cost ours / Ceres (px²) | mean 3D error ours / Ceres (mm) | ours cost ≤ Ceres |"
    )?;
    writeln!(s, "|---|---|---|---|---|---|---|---|---|---|")?;
    let mut details = String::new();
    for c in cases {
        let costs = |o: &[Outcome]| -> Vec<f64> {
            o.iter()
                .zip(&c.problems)
                .map(|(o, p)| cost(sk, cam, &p.keypoints, &o.pose, opts))
                .collect()
        };
        let errs = |o: &[Outcome]| -> Vec<f64> {
            o.iter()
                .zip(&c.problems)
                .map(|(o, p)| mean_error(sk, &o.pose, &truth[p.frame]))
                .collect()
        };
        let times = |o: &[Outcome]| -> Vec<f64> { o.iter().map(|o| o.time_ns / 1e3).collect() };
        let iters = |o: &[Outcome]| -> Vec<f64> { o.iter().map(|o| o.iterations as f64).collect() };
        let (co, cc) = (costs(&c.ours_lm), costs(&c.ceres));
        let (eo, ec) = (errs(&c.ours_lm), errs(&c.ceres));
        let (to, tc) = (median(&mut times(&c.ours_lm)), median(&mut times(&c.ceres)));
        let n = c.problems.len();
        let le = co
            .iter()
            .zip(&cc)
            .filter(|(o, e)| **o <= **e * (1.0 + COST_RTOL) + COST_ATOL)
            .count();
        writeln!(
            s,
            "| {} px, {} | {} | {:.1} | {:.1} | {:.1}x | {} / {} | {:.4} / {:.4} | {:.4} / {:.4} | {:.2} / {:.2} | {} / {} ({:.1}%) |",
            c.noise,
            if c.warm { "warm start" } else { "from scratch (LM part)" },
            n,
            to,
            tc,
            tc / to,
            median(&mut iters(&c.ours_lm)),
            median(&mut iters(&c.ceres)),
            median(&mut co.clone()),
            median(&mut cc.clone()),
            mean(&co),
            mean(&cc),
            mean(&eo),
            mean(&ec),
            le,
            n,
            100.0 * le as f64 / n as f64
        )?;
        // Details: where the costs differ, per-problem speed ratios, the full fit.
        let full = (!c.ours_full.is_empty()).then(|| {
            (
                costs(&c.ours_full),
                errs(&c.ours_full),
                median(&mut times(&c.ours_full)),
            )
        });
        case_details(&mut details, c, (&co, &cc), tc, full)?;
    }
    writeln!(s, "\n{details}")?;
    Ok(s)
}

/// The details of one case: where the costs differ, per-problem speed ratios, and our
/// whole fit (`full`: its costs, 3D errors and median time) when it was timed.
fn case_details(
    details: &mut String,
    c: &Case,
    (co, cc): (&[f64], &[f64]),
    tc: f64,
    full: Option<(Vec<f64>, Vec<f64>, f64)>,
) -> Res<()> {
    let n = c.problems.len();
    let worse: Vec<(usize, f64, f64)> = co
        .iter()
        .zip(cc)
        .enumerate()
        .filter(|(_, (o, e))| **o > **e * (1.0 + COST_RTOL) + COST_ATOL)
        .map(|(i, (o, e))| (c.problems[i].frame, *o, *e))
        .collect();
    let better = co
        .iter()
        .zip(cc)
        .filter(|(o, e)| **e > **o * (1.0 + COST_RTOL) + COST_ATOL)
        .count();
    let mut ratios: Vec<f64> = c
        .ceres
        .iter()
        .zip(&c.ours_lm)
        .map(|(e, o)| e.time_ns / o.time_ns)
        .collect();
    let mut cmin: Vec<f64> = c.ceres_minimizer_ns.iter().map(|v| v / 1e3).collect();
    writeln!(
        details,
        "- **{}**: per-solve speed ratio median {:.1}x (min {:.1}x); Ceres minimizer alone (no preprocessing) median {:.1} µs; \
         ours strictly lower cost on {better}, Ceres strictly lower on {} (ours ≤ Ceres within {COST_RTOL:e} relative).",
        c.name,
        median(&mut ratios),
        ratios.first().copied().unwrap_or(f64::NAN),
        median(&mut cmin),
        worse.len()
    )?;
    if !worse.is_empty() {
        let mut w = worse.clone();
        w.sort_by(|a, b| (b.1 - b.2).total_cmp(&(a.1 - a.2)));
        let top: Vec<String> = w
            .iter()
            .take(5)
            .map(|(f, o, e)| format!("frame {f}: {o:.4} vs {e:.4}"))
            .collect();
        writeln!(
            details,
            "  Largest gaps (ours vs Ceres cost): {}.",
            top.join("; ")
        )?;
    }
    if let Some((cf, ef, tf)) = full {
        let lef = cf
            .iter()
            .zip(cc)
            .filter(|(o, e)| **o <= **e * (1.0 + COST_RTOL) + COST_ATOL)
            .count();
        writeln!(
            details,
            "  Our whole `fit` (initialisation + LM + second pass): median {:.1} µs ({:.1}x faster than Ceres' LM alone), \
             median / mean cost {:.4} / {:.4}, mean 3D error {:.2} mm, cost ≤ Ceres on {lef} / {n}.",
            tf,
            tc / tf,
            median(&mut cf.clone()),
            mean(&cf),
            mean(&ef)
        )?;
    }
    Ok(())
}
