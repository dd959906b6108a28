//! Running an evaluation: keypoints from a [`KeypointSource`] (projected labels for
//! `--stage lift`) fitted per frame in each [`ViewMode`] and compared with the ground
//! truth; the run results and their summaries, which `--stage full` ([`crate::full`], the
//! engine over each sequence) fills too.
//!
//! Decisions (documented in `docs/evaluation.md`):
//! - Mono and stereo see **the same frames and the same keypoints** (noise and
//!   dropped joints are drawn once per frame and view).
//! - Each frame is fitted **from scratch** unless the fit tracks ([`EvalSettings::fit`]),
//!   which warm-starts from the previous frame of the same sequence, mode and hand.
//! - Skeleton: [`SkeletonChoice::Subject`] fits the model to each sequence's
//!   ground truth (an oracle hand size: the bound of what the lifting can do);
//!   [`SkeletonChoice::Default`] uses the average adult hand times
//!   [`EvalSettings::hand_scale`].
//! - A hand whose fit fails (too few joints, no view) is **not detected**: it
//!   counts in the detection rate and is left out of the 3D errors.

use crate::dataset::{Dataset, Frame, GtHand, RootJoint};
use crate::error::{EvalError, EvalResult};
use crate::metrics::{self, HandErrors, JointMask, Joints, ALL_JOINTS};
use monohand::FitSettings;
use monohand_core::fitting::estimate_proportions;
use monohand_core::hand_model::fit_skeleton;
use monohand_core::observation::NetworkCues;
use monohand_core::prelude::*;
use nalgebra::Vector3;
use rand::rngs::StdRng;
use rand::seq::index::sample;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::collections::HashMap;
use std::time::Instant;

/// Which cameras a fit uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ViewMode {
    /// The first camera alone.
    Mono,
    /// Every camera of the frame (at least two).
    Stereo,
}

impl ViewMode {
    /// `"mono"` or `"stereo"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            ViewMode::Mono => "mono",
            ViewMode::Stereo => "stereo",
        }
    }
}

/// Which hand model the fitter uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SkeletonChoice {
    /// Fitted to each sequence's ground-truth 3D joints (`fit_skeleton`).
    Subject,
    /// The default adult hand, scaled by [`EvalSettings::hand_scale`].
    Default,
}

impl SkeletonChoice {
    /// `"subject"` or `"default"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            SkeletonChoice::Subject => "subject",
            SkeletonChoice::Default => "default",
        }
    }
}

/// Settings of one evaluation run.
#[derive(Debug, Clone, PartialEq)]
pub struct EvalSettings {
    /// The view modes to evaluate, each on the same frames.
    pub modes: Vec<ViewMode>,
    /// The hand model.
    pub skeleton: SkeletonChoice,
    /// Scale of the default skeleton (ignored for [`SkeletonChoice::Subject`]).
    pub hand_scale: f64,
    /// How the hands are fitted: the library's own settings, as `run` and `lift` take them
    /// (their skeletons are replaced by [`EvalSettings::skeleton`]'s, per sequence).
    /// - `tracking` warm-starts each fit from the previous frame of the same sequence,
    ///   mode and hand;
    /// - `proportion_frames` learns the hand's proportions from the network's 3D of this
    ///   many first frames of each sequence and hand ([`estimate_proportions`]);
    /// - the full stage runs `run`'s engine with all of it (the depth filter and the
    ///   offline smoother included);
    /// - the lift stage fits from keypoints as `lift` does, and refuses what needs the
    ///   images or the engine ([`monohand::ResolvedSettings::lifting`]).
    pub fit: FitSettings,
    /// The full stage with several cameras: each view's crops from the hands fitted in 3D
    /// ([`monohand::Settings::fitted_crops`]).
    pub fitted_crops: bool,
}

impl Default for EvalSettings {
    /// Both view modes, the subject's skeleton, every frame fitted from scratch with the
    /// library's default fit.
    fn default() -> Self {
        EvalSettings {
            modes: vec![ViewMode::Mono, ViewMode::Stereo],
            skeleton: SkeletonChoice::Subject,
            hand_scale: 1.0,
            fit: FitSettings {
                tracking: false,
                ..FitSettings::default()
            },
            fitted_crops: true,
        }
    }
}

impl EvalSettings {
    /// As [`EvalSettings::default`], with each fit tracked as `run` tracks a video (the
    /// library's default fit: the depth filter on).
    pub fn tracked() -> EvalSettings {
        EvalSettings {
            fit: FitSettings::default(),
            ..EvalSettings::default()
        }
    }

    /// The library's settings for these fits with `skeletons`, resolved: what the engine
    /// runs with in the full stage (`pipeline`: the networks' options as loaded,
    /// `detect_every`: the detection cadence).
    pub fn resolve(
        &self,
        skeletons: [HandSkeleton; 2],
        pipeline: monohand::vision::PipelineOptions,
        detect_every: usize,
    ) -> EvalResult<monohand::ResolvedSettings> {
        monohand::Settings {
            pipeline,
            fit: FitSettings {
                skeletons,
                ..self.fit
            },
            detect_every,
            fitted_crops: self.fitted_crops,
            ..monohand::Settings::default()
        }
        .resolve()
        .map_err(EvalError::Refused)
    }

    /// Checks that the lift stage can fit with these settings: from keypoints alone, as
    /// `lift` does.
    fn check_lifting(&self) -> EvalResult<()> {
        let resolved = self.resolve(
            self.fit.skeletons,
            monohand::vision::PipelineOptions::default(),
            1,
        )?;
        resolved.lifting().map_err(EvalError::Refused)?;
        Ok(())
    }
}

/// What gives the fitter its 2D keypoints.
pub trait KeypointSource {
    /// A one-line description for the report ("projected labels, 2 px noise").
    fn describe(&self) -> String;
    /// The keypoints (and the network's 3D cues, if any) of every ground-truth
    /// hand of a frame in every view: `out[hand][view]`, `None` where the hand
    /// was not found in that view.
    fn keypoints(&mut self, frame: &Frame) -> EvalResult<Vec<Vec<Option<HandObservation>>>>;
}

/// `--stage lift`: the ground-truth 2D keypoints (labelled, or the 3D labels
/// projected), with optional Gaussian noise and dropped joints.
#[derive(Debug, Clone)]
pub struct ProjectedLabels {
    noise_px: f64,
    drop_joints: usize,
    rng: StdRng,
}

impl ProjectedLabels {
    /// Noise of standard deviation `noise_px` per pixel coordinate; `drop_joints`
    /// joints chosen at random per view get confidence 0; `seed` fixes both.
    pub fn new(noise_px: f64, drop_joints: usize, seed: u64) -> EvalResult<ProjectedLabels> {
        if !(noise_px.is_finite() && noise_px >= 0.0) {
            return Err(EvalError::Settings(format!(
                "noise {noise_px} px must be a finite number >= 0"
            )));
        }
        if drop_joints > NUM_JOINTS {
            return Err(EvalError::Settings(format!(
                "cannot drop {drop_joints} of {NUM_JOINTS} joints"
            )));
        }
        Ok(ProjectedLabels {
            noise_px,
            drop_joints,
            rng: StdRng::seed_from_u64(seed),
        })
    }
}

impl KeypointSource for ProjectedLabels {
    fn describe(&self) -> String {
        format!(
            "ground-truth 2D keypoints, Gaussian noise sigma {} px per coordinate, {} joints dropped per view",
            self.noise_px, self.drop_joints
        )
    }

    fn keypoints(&mut self, frame: &Frame) -> EvalResult<Vec<Vec<Option<HandObservation>>>> {
        let normal = Normal::new(0.0, self.noise_px.max(1e-300))
            .map_err(|e| EvalError::Settings(e.to_string()))?;
        let mut out = Vec::with_capacity(frame.hands.len());
        for h in 0..frame.hands.len() {
            let mut views = Vec::with_capacity(frame.cameras.len());
            for v in 0..frame.cameras.len() {
                let mut kp = frame.gt_keypoints(h, v);
                for p in kp.points.iter_mut() {
                    // Drawn for every joint so that the stream does not depend on the data.
                    let (du, dv) = (normal.sample(&mut self.rng), normal.sample(&mut self.rng));
                    if self.noise_px > 0.0 {
                        p[0] += du;
                        p[1] += dv;
                    }
                }
                if self.drop_joints > 0 {
                    for j in sample(&mut self.rng, NUM_JOINTS, self.drop_joints) {
                        kp.points[j][2] = 0.0;
                    }
                }
                views.push(Some(HandObservation {
                    side: frame.hands[h].side,
                    keypoints: kp,
                    cues: None,
                }));
            }
            out.push(views);
        }
        Ok(out)
    }
}

/// The outcome for one ground-truth hand in one frame and mode.
#[derive(Debug, Clone, PartialEq)]
pub struct HandResult {
    /// Sequence name.
    pub sequence: String,
    /// Frame index in the sequence.
    pub frame: usize,
    /// Which hand.
    pub side: HandSide,
    /// The fitted joints (mm, first camera frame), `None` if not detected.
    pub pred: Option<Joints>,
    /// The ground truth.
    pub gt: Joints,
    /// The errors, `None` if not detected.
    pub errors: Option<HandErrors>,
    /// Mean 2D error of the input keypoints in the first view against the
    /// ground truth (pixels), over joints present in both.
    pub keypoints_px: Option<f64>,
    /// Mean 2D error of the fitted joints projected into the first view
    /// against the ground-truth 2D keypoints (pixels).
    pub reprojection_px: Option<f64>,
    /// The fitted hand's distance from the first camera over the true one's
    /// ([`metrics::depth_ratio`]; above 1: too far), `None` if not detected.
    pub depth_ratio: Option<f64>,
    /// Time spent on this hand: keypoint source share + fit (seconds).
    pub seconds: f64,
}

/// Every hand of a run: one mode, one keypoint source.
#[derive(Debug, Clone, PartialEq)]
pub struct RunResult {
    /// A short label, e.g. "mono, 2 px".
    pub label: String,
    /// The view mode.
    pub mode: ViewMode,
    /// The keypoint source's description.
    pub source: String,
    /// The input noise (pixels) for lift runs, `None` for detector runs.
    pub noise_px: Option<f64>,
    /// True for the keypoint network's own relative 3D (its "world" landmarks),
    /// which has no position: its joints are placed at the ground truth's
    /// centroid, and the absolute metrics and jitter are not defined.
    pub relative_only: bool,
    /// Per-hand outcomes in dataset order.
    pub hands: Vec<HandResult>,
}

/// Label of the run that scores the keypoint network's own 3D.
pub const NETWORK_RUN_LABEL: &str = "network 3D (no position)";

/// One skeleton used in a run, and how well it explains the ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct SkeletonNote {
    /// The sequence.
    pub sequence: String,
    /// Which hand.
    pub side: HandSide,
    /// Mean residual of `fit_skeleton` on the ground truth (mm); `None` for the default skeleton.
    pub residual_mm: Option<f64>,
    /// The skeleton's wrist-to-middle-tip length (mm).
    pub hand_length_mm: f64,
}

/// The evaluated-joint mask for a root convention: all 21 points (for STB the
/// palm centre and the 20 finger joints, as published STB numbers are computed).
pub fn evaluated_joints(_root: RootJoint) -> JointMask {
    ALL_JOINTS
}

/// Skeletons by (sequence, side).
pub type SkeletonMap = HashMap<(String, HandSide), HandSkeleton>;

/// The skeletons a run will use, by (sequence, side).
pub fn skeletons(
    dataset: &Dataset,
    settings: &EvalSettings,
) -> EvalResult<(SkeletonMap, Vec<SkeletonNote>)> {
    let mut gt: HashMap<(String, HandSide), Vec<[Vector3<f64>; NUM_JOINTS]>> = HashMap::new();
    let mut order = Vec::new();
    for f in &dataset.frames {
        for h in &f.hands {
            let key = (f.sequence.clone(), h.side);
            if !gt.contains_key(&key) {
                order.push(key.clone());
            }
            // The subject's skeleton is fitted to the frames where every joint is labelled.
            let joints = gt.entry(key).or_default();
            if h.joints_3d.iter().flatten().all(|x| x.is_finite()) {
                joints.push(h.joints_3d.map(|p| Vector3::new(p[0], p[1], p[2])));
            }
        }
    }
    let mut map = HashMap::new();
    let mut notes = Vec::new();
    for key in order {
        let template = HandSkeleton::default_for(key.1);
        let (sk, residual) = match settings.skeleton {
            SkeletonChoice::Subject => {
                let fit = fit_skeleton(&gt[&key], &template).map_err(|e| {
                    EvalError::core(format!("fitting the skeleton of sequence {:?}", key.0), e)
                })?;
                (fit.skeleton, Some(fit.residual_mm))
            }
            SkeletonChoice::Default => (
                template
                    .scaled(settings.hand_scale)
                    .map_err(|e| EvalError::core("--hand-scale", e))?,
                None,
            ),
        };
        notes.push(SkeletonNote {
            sequence: key.0.clone(),
            side: key.1,
            residual_mm: residual,
            hand_length_mm: sk.hand_length(),
        });
        map.insert(key, sk);
    }
    Ok((map, notes))
}

/// Runs every mode of `settings` over the dataset with keypoints from `source`.
/// `noise_px` is only recorded (for labels and plots).
pub fn evaluate(
    dataset: &Dataset,
    source: &mut dyn KeypointSource,
    settings: &EvalSettings,
    noise_px: Option<f64>,
) -> EvalResult<(Vec<RunResult>, Vec<SkeletonNote>)> {
    check_settings(dataset, settings)?;
    settings.check_lifting()?;
    let (sks, notes) = skeletons(dataset, settings)?;
    let (mut runs, mut network) = empty_runs(settings, &source.describe(), noise_px);
    let mut network_seen = false;
    let mut evaluator = Evaluator {
        settings,
        sks,
        mask: evaluated_joints(dataset.root),
        palm_root: dataset.root == RootJoint::PalmCentre,
        default_sk: settings.skeleton == SkeletonChoice::Default,
        gathered: HashMap::new(),
        learnt: HashMap::new(),
        solvers: HashMap::new(),
    };
    for frame in &dataset.frames {
        let t0 = Instant::now();
        let mut kps = source.keypoints(frame)?;
        let source_s = t0.elapsed().as_secs_f64() / frame.hands.len().max(1) as f64;
        for h in 0..frame.hands.len() {
            let views_kp = kps.get_mut(h).ok_or_else(|| {
                EvalError::Detector("the keypoint source returned fewer hands than labelled".into())
            })?;
            network_seen |=
                evaluator.hand(frame, h, views_kp, source_s, &mut runs, &mut network)?;
        }
    }
    if network_seen {
        runs.push(network);
    }
    Ok((runs, notes))
}

/// Checks that `settings` can be evaluated on `dataset`: at least one view mode, two
/// cameras in every frame for stereo, valid fit options.
pub(crate) fn check_settings(dataset: &Dataset, settings: &EvalSettings) -> EvalResult<()> {
    if settings.modes.is_empty() {
        return Err(EvalError::Settings("no view mode to evaluate".into()));
    }
    if settings.modes.contains(&ViewMode::Stereo) {
        if let Some(f) = dataset.frames.iter().find(|f| f.cameras.len() < 2) {
            return Err(EvalError::Settings(format!(
                "stereo needs two cameras, frame {} of sequence {:?} has one",
                f.index, f.sequence
            )));
        }
    }
    settings
        .fit
        .options
        .validate()
        .map_err(|e| EvalError::core("fit options", e))
}

/// The runs of an evaluation before any hand: one per mode of `settings`, and the run of
/// the network's own 3D; `desc` describes the keypoint source.
pub(crate) fn empty_runs(
    settings: &EvalSettings,
    desc: &str,
    noise_px: Option<f64>,
) -> (Vec<RunResult>, RunResult) {
    let runs: Vec<RunResult> = settings
        .modes
        .iter()
        .map(|&mode| RunResult {
            label: match noise_px {
                Some(n) => format!("{}, {n} px", mode.as_str()),
                None => mode.as_str().to_string(),
            },
            mode,
            source: desc.to_string(),
            noise_px,
            relative_only: false,
            hands: Vec::new(),
        })
        .collect();
    // The network's own 3D of the first view, scored beside the fits when the
    // source gives it (same frames, same detections).
    let network = RunResult {
        label: NETWORK_RUN_LABEL.to_string(),
        mode: ViewMode::Mono,
        source: format!("{desc}; its metric 3D landmarks, first view"),
        noise_px,
        relative_only: true,
        hands: Vec::new(),
    };
    (runs, network)
}

/// One labelled hand of a frame, as every run sees it.
struct HandInput<'a> {
    frame: &'a Frame,
    hand: &'a GtHand,
    /// The hand's keypoints in each view (`None` where it was not found).
    views: &'a [Option<HandObservation>],
    /// Its ground-truth 2D keypoints in the first view.
    gt2d: Keypoints2d,
    /// Mean 2D error of its keypoints in the first view (pixels).
    keypoints_px: Option<f64>,
    /// The keypoint source's time for it (seconds).
    source_s: f64,
}

/// What an evaluation carries from hand to hand: the settings and skeletons, the
/// proportions being learnt, and the trackers.
struct Evaluator<'a> {
    settings: &'a EvalSettings,
    sks: SkeletonMap,
    mask: JointMask,
    /// The ground truth's joint 0 is the palm centre.
    palm_root: bool,
    /// The fits use the default skeleton (whose joint 0 is a wrist).
    default_sk: bool,
    /// Network 3D gathered per (sequence, side) until the proportions are learnt.
    gathered: HashMap<(String, HandSide), Vec<NetworkCues>>,
    /// The learnt skeletons per (sequence, side).
    learnt: HashMap<(String, HandSide), HandSkeleton>,
    /// One tracker per (mode, sequence, side); without tracking it is reset
    /// before every frame, i.e. every fit starts from scratch.
    solvers: HashMap<(usize, String, HandSide), HandTracker>,
}

impl Evaluator<'_> {
    /// Evaluates hand `h` of `frame` with its keypoints `views_kp` in every run of `runs`
    /// and in `network`; returns whether the keypoint source gave the network's 3D.
    fn hand(
        &mut self,
        frame: &Frame,
        h: usize,
        views_kp: &mut [Option<HandObservation>],
        source_s: f64,
        runs: &mut [RunResult],
        network: &mut RunResult,
    ) -> EvalResult<bool> {
        if self.palm_root && self.default_sk {
            // The default model's joint 0 is a wrist: never feed it the palm centre.
            for o in views_kp.iter_mut().flatten() {
                o.keypoints.points[0][2] = 0.0;
            }
        }
        let gt2d = frame.gt_keypoints(h, 0);
        let first = views_kp.first().copied().flatten();
        let keypoints_px = first.and_then(|o| {
            mean_px(&metrics::keypoint_errors_px(
                &o.keypoints.points,
                &gt2d.points,
            ))
        });
        let input = HandInput {
            frame,
            hand: &frame.hands[h],
            views: views_kp,
            gt2d,
            keypoints_px,
            source_s,
        };
        let world = first.and_then(|o| o.cues).and_then(|c| c.world_mm);
        network.hands.push(self.network_result(&input, world));
        let sk = self.skeleton(&input, first)?;
        for (m, run) in runs.iter_mut().enumerate() {
            run.hands.push(self.fit(m, run.mode, &input, sk)?);
        }
        Ok(world.is_some())
    }

    /// The network's own 3D `world` of a hand, placed at the ground truth's centroid.
    fn network_result(&self, input: &HandInput, world: Option<Joints>) -> HandResult {
        let (frame, hand, mask) = (input.frame, input.hand, &self.mask);
        let network_pred = world.map(|w| {
            let labelled = metrics::labelled(&hand.joints_3d, mask);
            let (cw, cg) = (
                metrics::centroid(&w, &labelled),
                metrics::centroid(&hand.joints_3d, &labelled),
            );
            w.map(|p| std::array::from_fn(|k| p[k] - cw[k] + cg[k]))
        });
        HandResult {
            sequence: frame.sequence.clone(),
            frame: frame.index,
            side: hand.side,
            errors: network_pred.map(|p| HandErrors::compute(&p, &hand.joints_3d, mask, 0)),
            pred: network_pred,
            gt: hand.joints_3d,
            keypoints_px: input.keypoints_px,
            reprojection_px: None,
            depth_ratio: None,
            seconds: input.source_s,
        }
    }

    /// The skeleton to fit a hand with: its sequence's, or the proportions learnt from
    /// the network's 3D (`first`, the observation in the first view, adds to them).
    fn skeleton(
        &mut self,
        input: &HandInput,
        first: Option<HandObservation>,
    ) -> EvalResult<HandSkeleton> {
        let (frame, hand) = (input.frame, input.hand);
        let key_sk = (frame.sequence.clone(), hand.side);
        let mut sk = self.sks.get(&key_sk).copied().ok_or_else(|| {
            EvalError::Settings(format!("no skeleton for sequence {:?}", frame.sequence))
        })?;
        if let Some(n) = self.settings.fit.proportion_frames {
            let cues = first.and_then(|o| o.cues);
            if let (Some(c), false) = (cues, self.learnt.contains_key(&key_sk)) {
                let g = self.gathered.entry(key_sk.clone()).or_default();
                g.push(c);
                if g.len() >= n {
                    if let Ok(est) = estimate_proportions(&sk, g) {
                        self.learnt.insert(key_sk.clone(), est.skeleton);
                        for (key, t) in self.solvers.iter_mut() {
                            if key.1 == key_sk.0 && key.2 == key_sk.1 {
                                t.set_skeleton(est.skeleton)
                                    .map_err(|e| EvalError::core("learnt proportions", e))?;
                            }
                        }
                    }
                }
            }
            if let Some(l) = self.learnt.get(&key_sk) {
                sk = *l;
            }
        }
        Ok(sk)
    }

    /// Fits a hand in view mode `mode` (run `m`) with the skeleton `sk`, with the run's
    /// tracker; its result.
    fn fit(
        &mut self,
        m: usize,
        mode: ViewMode,
        input: &HandInput,
        sk: HandSkeleton,
    ) -> EvalResult<HandResult> {
        let (frame, hand, mask) = (input.frame, input.hand, &self.mask);
        let n_views = match mode {
            ViewMode::Mono => 1,
            ViewMode::Stereo => frame.cameras.len(),
        };
        let views: Vec<View> = frame.cameras[..n_views]
            .iter()
            .zip(input.views.iter())
            .filter_map(|(camera, o)| {
                o.as_ref()
                    .map(|o| View::new(camera, &o.keypoints).with_cues(o.cues.as_ref()))
            })
            .collect();
        let key = (m, frame.sequence.clone(), hand.side);
        if !self.solvers.contains_key(&key) {
            let t = HandTracker::new(sk, self.settings.fit.options)
                .map_err(|e| EvalError::core("creating the fitter", e))?;
            self.solvers.insert(key.clone(), t);
        }
        let t1 = Instant::now();
        let fit = match (views.is_empty(), self.solvers.get_mut(&key)) {
            (false, Some(t)) => {
                if !self.settings.fit.tracking {
                    t.reset();
                }
                t.update(&views).ok()
            }
            _ => None,
        };
        let fit_s = t1.elapsed().as_secs_f64();
        let pred = fit.map(|f| {
            let mut j = metrics::to_joints(&f.joints_3d);
            if self.palm_root && self.default_sk {
                j[0] = palm_centre_estimate(&f.joints_3d);
            }
            j
        });
        let errors = pred
            .as_ref()
            .map(|p| HandErrors::compute(p, &hand.joints_3d, mask, 0));
        let reprojection_px = pred.as_ref().and_then(|p| {
            let k = crate::dataset::project_joints(&frame.cameras[0], p);
            mean_px(&metrics::keypoint_errors_px(&k.points, &input.gt2d.points))
        });
        Ok(HandResult {
            sequence: frame.sequence.clone(),
            frame: frame.index,
            side: hand.side,
            pred,
            gt: hand.joints_3d,
            errors,
            keypoints_px: input.keypoints_px,
            depth_ratio: pred
                .as_ref()
                .and_then(|p| metrics::depth_ratio(p, &hand.joints_3d, mask, &frame.cameras[0])),
            reprojection_px,
            seconds: input.source_s + fit_s,
        })
    }
}

/// Where the default (wrist-rooted) model puts an STB-style palm centre: the
/// midpoint of the wrist and the middle-finger MCP.
pub fn palm_centre_estimate(joints: &[Vector3<f64>; NUM_JOINTS]) -> [f64; 3] {
    let c = (joints[0] + joints[9]) * 0.5;
    [c.x, c.y, c.z]
}

pub(crate) fn mean_px(e: &[Option<f64>; NUM_JOINTS]) -> Option<f64> {
    let v: Vec<f64> = e.iter().flatten().copied().collect();
    (!v.is_empty()).then(|| metrics::mean(&v))
}

/// The numbers of one run, as in the printed table.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// The run's label.
    pub label: String,
    /// Labelled hands.
    pub hands: usize,
    /// Hands with a fit.
    pub detected: usize,
    /// Mean absolute error over detected hands and evaluated joints (mm).
    pub mpjpe: f64,
    /// Median of the per-frame absolute error (mm).
    pub median: f64,
    /// Root-relative MPJPE (mm).
    pub root_relative: f64,
    /// Zimmermann-Brox aligned MPJPE (mm).
    pub aligned: f64,
    /// Procrustes-aligned MPJPE (mm).
    pub pa_mpjpe: f64,
    /// Centroid-aligned MPJPE (mm).
    pub centroid: f64,
    /// Jitter: mean joint acceleration over runs of three consecutive fitted
    /// frames, mm per frame squared (NaN without such runs, or for a
    /// relative-only run).
    pub jitter: f64,
    /// The same acceleration of the ground truth on those frames (the motion
    /// itself, a floor for the jitter).
    pub gt_jitter: f64,
    /// Mean absolute error along x, y, z (mm).
    pub axis: [f64; 3],
    /// AUC(20-50 mm) of the per-joint absolute PCK.
    pub auc_abs_joint: f64,
    /// AUC(20-50 mm) of the per-frame absolute PCK.
    pub auc_abs_frame: f64,
    /// AUC(20-50 mm) of the per-joint root-relative PCK.
    pub auc_rr_joint: f64,
    /// AUC(20-50 mm) of the per-joint Zimmermann-Brox aligned PCK (what STB tables quote).
    pub auc_aligned_joint: f64,
    /// AUC(20-50 mm) of the per-frame aligned PCK.
    pub auc_aligned_frame: f64,
    /// AUC(20-50 mm) of the per-joint Procrustes-aligned PCK.
    pub auc_pa_joint: f64,
    /// Mean 2D error of the input keypoints, first view (pixels).
    pub keypoints_px: f64,
    /// Mean 2D error of the fitted joints reprojected into the first view (pixels).
    pub reprojection_px: f64,
    /// Median over detected hands of the fitted distance over the true one, from the first
    /// camera ([`HandResult::depth_ratio`]; NaN for a relative-only run).
    pub depth_ratio: f64,
    /// Frames per second over keypoint source and fit.
    pub fps: f64,
}

/// Error lists of a run: pooled per joint and per frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ErrorLists {
    /// Every evaluated joint of every detected hand.
    pub joints: Vec<f64>,
    /// The mean over evaluated joints of every detected hand.
    pub frames: Vec<f64>,
}

impl RunResult {
    /// The run split in two: the first and the second half of each sequence's frames (by
    /// frame index; an odd count puts the middle frame in the second half). A setting
    /// chosen on a dataset should help on both halves; a gain on one half only is noise.
    pub fn halves(&self) -> [RunResult; 2] {
        let mut frames: HashMap<&str, Vec<usize>> = HashMap::new();
        for h in &self.hands {
            frames.entry(&h.sequence).or_default().push(h.frame);
        }
        for f in frames.values_mut() {
            f.sort_unstable();
            f.dedup();
        }
        let first = |h: &HandResult| {
            let f = &frames[h.sequence.as_str()];
            f.partition_point(|&i| i < h.frame) < f.len() / 2
        };
        let half = |which: bool, name: &str| RunResult {
            label: format!("{}, {name} half", self.label),
            hands: self
                .hands
                .iter()
                .filter(|h| first(h) == which)
                .cloned()
                .collect(),
            ..self.clone()
        };
        [half(true, "1st"), half(false, "2nd")]
    }

    /// The pooled error lists of one metric, picked by `pick`.
    pub fn errors(
        &self,
        mask: &JointMask,
        pick: impl Fn(&HandErrors) -> &[f64; NUM_JOINTS],
    ) -> ErrorLists {
        let mut out = ErrorLists::default();
        for e in self.hands.iter().filter_map(|h| h.errors.as_ref()) {
            let a = pick(e);
            // A joint without ground truth has a NaN error, a hand without any a NaN mean.
            out.joints.extend(
                (0..NUM_JOINTS)
                    .filter(|&j| mask[j] && !a[j].is_nan())
                    .map(|j| a[j]),
            );
            let frame = metrics::masked_mean(a, mask);
            if !frame.is_nan() {
                out.frames.push(frame);
            }
        }
        out
    }

    /// Per hand, the jitter term of the three consecutive frames centred on it (one
    /// sequence and side, all three predicted): the acceleration of the prediction and of
    /// the ground truth (mm per frame squared, [`metrics::acceleration`]); `None` at a
    /// sequence's ends, next to a gap or a missed hand. The jitter is their mean.
    pub fn accelerations(&self, mask: &JointMask) -> Vec<Option<(f64, f64)>> {
        let mut out = vec![None; self.hands.len()];
        for (i, w) in self.hands.windows(3).enumerate() {
            let same = w
                .iter()
                .all(|h| h.sequence == w[0].sequence && h.side == w[0].side);
            let consecutive = w[1].frame == w[0].frame + 1 && w[2].frame == w[1].frame + 1;
            if let (true, true, Some(a), Some(b), Some(c)) =
                (same, consecutive, &w[0].pred, &w[1].pred, &w[2].pred)
            {
                out[i + 1] = Some((
                    metrics::acceleration(a, b, c, mask),
                    metrics::acceleration(&w[0].gt, &w[1].gt, &w[2].gt, mask),
                ));
            }
        }
        out
    }

    /// The summary numbers.
    pub fn summary(&self, mask: &JointMask) -> RunSummary {
        let (lo, hi) = metrics::AUC_RANGE_MM;
        let abs = self.errors(mask, |e| &e.absolute);
        let rr = self.errors(mask, |e| &e.root_relative);
        let al = self.errors(mask, |e| &e.aligned);
        let pa = self.errors(mask, |e| &e.procrustes);
        let ce = self.errors(mask, |e| &e.centroid);
        let (acc, gt_acc): (Vec<f64>, Vec<f64>) =
            self.accelerations(mask).into_iter().flatten().unzip();
        let nan_if_relative = |x: f64| if self.relative_only { f64::NAN } else { x };
        let det: Vec<&HandErrors> = self
            .hands
            .iter()
            .filter_map(|h| h.errors.as_ref())
            .collect();
        let axis = std::array::from_fn(|a| {
            metrics::mean(&det.iter().map(|e| e.axis[a]).collect::<Vec<_>>())
        });
        let kp: Vec<f64> = self.hands.iter().filter_map(|h| h.keypoints_px).collect();
        let rp: Vec<f64> = self
            .hands
            .iter()
            .filter_map(|h| h.reprojection_px)
            .collect();
        let secs: f64 = self.hands.iter().map(|h| h.seconds).sum();
        RunSummary {
            label: self.label.clone(),
            hands: self.hands.len(),
            detected: det.len(),
            mpjpe: nan_if_relative(metrics::mean(&abs.joints)),
            median: nan_if_relative(metrics::quantile(&abs.frames, 0.5)),
            root_relative: metrics::mean(&rr.joints),
            aligned: metrics::mean(&al.joints),
            pa_mpjpe: metrics::mean(&pa.joints),
            centroid: metrics::mean(&ce.joints),
            jitter: nan_if_relative(metrics::mean(&acc)),
            gt_jitter: metrics::mean(&gt_acc),
            axis: axis.map(nan_if_relative),
            auc_abs_joint: nan_if_relative(metrics::auc(&abs.joints, lo, hi)),
            auc_abs_frame: nan_if_relative(metrics::auc(&abs.frames, lo, hi)),
            auc_rr_joint: metrics::auc(&rr.joints, lo, hi),
            auc_aligned_joint: metrics::auc(&al.joints, lo, hi),
            auc_aligned_frame: metrics::auc(&al.frames, lo, hi),
            auc_pa_joint: metrics::auc(&pa.joints, lo, hi),
            keypoints_px: metrics::mean(&kp),
            reprojection_px: metrics::mean(&rp),
            depth_ratio: metrics::quantile(
                &self
                    .hands
                    .iter()
                    .filter_map(|h| h.depth_ratio)
                    .collect::<Vec<_>>(),
                0.5,
            ),
            fps: if secs > 0.0 {
                self.hands.len() as f64 / secs
            } else {
                f64::NAN
            },
        }
    }
}

impl RunSummary {
    /// Fraction of labelled hands with a fit.
    pub fn detection_rate(&self) -> f64 {
        if self.hands == 0 {
            0.0
        } else {
            self.detected as f64 / self.hands as f64
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hand(sequence: &str, frame: usize, error: f64) -> HandResult {
        let gt = [[0.0, 0.0, 500.0]; NUM_JOINTS];
        let pred = gt.map(|p| [p[0] + error, p[1], p[2]]);
        HandResult {
            sequence: sequence.into(),
            frame,
            side: HandSide::Left,
            errors: Some(HandErrors::compute(&pred, &gt, &ALL_JOINTS, 0)),
            pred: Some(pred),
            gt,
            keypoints_px: None,
            reprojection_px: None,
            depth_ratio: None,
            seconds: 0.01,
        }
    }

    /// A mono run of `hands`.
    fn mono_run(hands: Vec<HandResult>) -> RunResult {
        RunResult {
            label: "mono".into(),
            mode: ViewMode::Mono,
            source: "test".into(),
            noise_px: None,
            relative_only: false,
            hands,
        }
    }

    #[test]
    fn halves_split_each_sequence_by_frame_index() {
        // Sequence a: frames 0-3 (2 + 2); sequence b: frames 10-14 (2 + 3), out of order.
        let mut hands: Vec<HandResult> = (0..4).map(|i| hand("a", i, 1.0 + i as f64)).collect();
        for i in [14, 10, 13, 11, 12] {
            hands.push(hand("b", i, 10.0));
        }
        let run = mono_run(hands);
        let [first, second] = run.halves();
        let frames = |r: &RunResult| -> Vec<(String, usize)> {
            r.hands
                .iter()
                .map(|h| (h.sequence.clone(), h.frame))
                .collect()
        };
        assert_eq!(
            frames(&first),
            [("a", 0), ("a", 1), ("b", 10), ("b", 11)].map(|(s, f)| (s.to_string(), f))
        );
        assert_eq!(
            frames(&second),
            [("a", 2), ("a", 3), ("b", 14), ("b", 13), ("b", 12)].map(|(s, f)| (s.to_string(), f))
        );
        assert_eq!(first.label, "mono, 1st half");
        let mean = |r: &RunResult| r.summary(&ALL_JOINTS).mpjpe;
        assert!((mean(&first) - (1.0 + 2.0 + 10.0 + 10.0) / 4.0).abs() < 1e-9);
        assert!((mean(&second) - (3.0 + 4.0 + 30.0) / 5.0).abs() < 1e-9);
    }

    /// Each hand's acceleration is that of the three frames centred on it, none at a
    /// sequence's ends, next to a gap or a missed hand; their mean is the run's jitter.
    #[test]
    fn accelerations_are_per_centre_frame_and_average_to_the_jitter() {
        // x offsets 0, 1, 4, 10 (second differences 2 and 3 mm), then a gap (frame 5), a
        // frame missed (7), and another sequence.
        let mut hands: Vec<HandResult> = [0.0, 1.0, 4.0, 10.0]
            .iter()
            .enumerate()
            .map(|(i, &e)| hand("a", i, e))
            .collect();
        hands.push(hand("a", 5, 0.0));
        hands.push(hand("a", 6, 0.0));
        let mut missed = hand("a", 7, 0.0);
        missed.pred = None;
        missed.errors = None;
        hands.push(missed);
        hands.push(hand("b", 8, 0.0));
        let run = mono_run(hands);
        let acc: Vec<Option<f64>> = run
            .accelerations(&ALL_JOINTS)
            .into_iter()
            .map(|a| {
                a.map(|(pred, gt)| {
                    assert_eq!(gt, 0.0);
                    pred
                })
            })
            .collect();
        assert_eq!(
            acc,
            [None, Some(2.0), Some(3.0), None, None, None, None, None]
        );
        assert_eq!(run.summary(&ALL_JOINTS).jitter, 2.5);
    }
}
