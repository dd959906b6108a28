//! The printed table and the report folder: `report.md` (settings, table,
//! embedded plots), `errors.csv` (raw per-hand errors) and PNG plots.

pub mod plot;

use crate::dataset::{Dataset, RootJoint};
use crate::error::{EvalError, EvalResult};
use crate::evaluate::{RunResult, RunSummary, SkeletonNote, NETWORK_RUN_LABEL};
use crate::metrics::{self, JointMask, AUC_RANGE_MM};
use monohand_core::hand_model::{JOINT_NAMES, NUM_JOINTS};
use plot::{Chart, Line};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Published STB results the report quotes (AUC of the 3D PCK over 20-50 mm,
/// root- and scale-aligned per Zimmermann & Brox, per joint, full pipeline on
/// the STB test set).
pub const PUBLISHED_STB: [(&str, f64); 2] = [
    ("Panteleris et al., WACV 2018", 0.941),
    ("Zimmermann & Brox, ICCV 2017", 0.948),
];

/// Everything a report shows.
#[derive(Debug, Clone)]
pub struct Report {
    /// Dataset name.
    pub dataset: String,
    /// Where it was read from.
    pub source: PathBuf,
    /// Root convention of the ground truth.
    pub root: RootJoint,
    /// `"lift"` or `"full"`.
    pub stage: String,
    /// Settings as (name, value) lines.
    pub settings: Vec<(String, String)>,
    /// Evaluated joints.
    pub mask: JointMask,
    /// Every run (mode x noise level).
    pub runs: Vec<RunResult>,
    /// The skeletons used.
    pub skeletons: Vec<SkeletonNote>,
    /// The monohand version.
    pub version: String,
}

fn f(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "-".into()
    }
}

impl Report {
    /// A report for `dataset`.
    pub fn new(dataset: &Dataset, stage: &str, mask: JointMask) -> Report {
        Report {
            dataset: dataset.name.clone(),
            source: dataset.source.clone(),
            root: dataset.root,
            stage: stage.to_string(),
            settings: Vec::new(),
            mask,
            runs: Vec::new(),
            skeletons: Vec::new(),
            version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }

    /// The summary of every run.
    pub fn summaries(&self) -> Vec<RunSummary> {
        self.runs.iter().map(|r| r.summary(&self.mask)).collect()
    }

    /// The results table (Markdown; also readable as plain text).
    pub fn table(&self) -> String {
        let mut s = String::new();
        s.push_str(
            "| run | hands | detected | MPJPE abs (mm) | median (mm) | root-rel (mm) | aligned (mm) | centroid (mm) | PA-MPJPE (mm) | jitter (mm/f²) | x / y / z (mm) | AUC abs joints | AUC abs frames | AUC aligned joints | AUC aligned frames | AUC PA joints | 2D in (px) | reproj (px) | depth pred/true | labels' jitter (mm/f²) | fps |\n",
        );
        s.push_str(
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        );
        let summaries = self.summaries();
        for r in &summaries {
            let _ = writeln!(
                s,
                "| {} | {} | {:.1}% | {} | {} | {} | {} | {} | {} | {} | {} / {} / {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                r.label,
                r.hands,
                100.0 * r.detection_rate(),
                f(r.mpjpe, 2),
                f(r.median, 2),
                f(r.root_relative, 2),
                f(r.aligned, 2),
                f(r.centroid, 2),
                f(r.pa_mpjpe, 2),
                f(r.jitter, 2),
                f(r.axis[0], 1),
                f(r.axis[1], 1),
                f(r.axis[2], 1),
                f(r.auc_abs_joint, 3),
                f(r.auc_abs_frame, 3),
                f(r.auc_aligned_joint, 3),
                f(r.auc_aligned_frame, 3),
                f(r.auc_pa_joint, 3),
                f(r.keypoints_px, 2),
                f(r.reprojection_px, 2),
                f(r.depth_ratio, 3),
                f(r.gt_jitter, 2),
                f(r.fps, 0),
            );
        }
        // Each fit against the network's 3D of its own view (`VIEW: network ...` for a
        // view evaluated alone), else of the first view.
        let is_network = |r: &RunSummary| r.label.ends_with(NETWORK_RUN_LABEL);
        for r in summaries.iter().filter(|r| !is_network(r)) {
            let own = format!("{}: {NETWORK_RUN_LABEL}", r.label);
            let network = summaries
                .iter()
                .find(|n| n.label == own)
                .or_else(|| summaries.iter().find(|n| n.label == NETWORK_RUN_LABEL));
            if let Some(n) = network {
                let _ = writeln!(
                    s,
                    "\n{} against the network's own 3D: PA-MPJPE {} x, centroid-aligned {} x, root-relative {} x",
                    r.label,
                    f(r.pa_mpjpe / n.pa_mpjpe, 2),
                    f(r.centroid / n.centroid, 2),
                    f(r.root_relative / n.root_relative, 2),
                );
            }
        }
        if let Some(r) = summaries.iter().find(|r| r.gt_jitter.is_finite()) {
            let _ = writeln!(
                s,
                "\nJitter of the ground truth itself on the same frames: {} mm/f²",
                f(r.gt_jitter, 2)
            );
        }
        s
    }

    /// The table of every run split into the first and second half of each sequence
    /// ([`RunResult::halves`]).
    pub fn halves_table(&self) -> String {
        let halves = Report {
            runs: self.runs.iter().flat_map(RunResult::halves).collect(),
            ..self.clone()
        };
        halves.table()
    }

    /// Writes `report.md`, `errors.csv` and the plots into `dir` (created if
    /// needed); returns the files written.
    pub fn write(&self, dir: &Path) -> EvalResult<Vec<PathBuf>> {
        std::fs::create_dir_all(dir).map_err(|e| EvalError::write(dir, e))?;
        let mut files = Vec::new();
        let csv = dir.join("errors.csv");
        std::fs::write(&csv, self.csv()).map_err(|e| EvalError::write(&csv, e))?;
        files.push(csv);
        let plots = self.plots(dir)?;
        let md = dir.join("report.md");
        std::fs::write(&md, self.markdown(&plots)).map_err(|e| EvalError::write(&md, e))?;
        files.push(md);
        files.extend(plots.into_iter().map(|(p, _)| p));
        Ok(files)
    }

    /// The raw per-hand errors: one row per run and labelled hand.
    pub fn csv(&self) -> String {
        let mut s = String::from(
            "run,mode,noise_px,sequence,frame,side,detected,mpjpe_mm,root_relative_mm,aligned_mm,pa_mm,abs_x_mm,abs_y_mm,abs_z_mm,keypoints_px,reprojection_px,seconds",
        );
        for (j, n) in JOINT_NAMES.iter().enumerate() {
            let n = if j == 0 && self.root == RootJoint::PalmCentre {
                "palm_centre"
            } else {
                n
            };
            let _ = write!(s, ",abs_{n}_mm");
        }
        s.push_str(",acceleration_mm_f2,depth_ratio\n");
        let opt = |x: Option<f64>| x.map(|v| format!("{v:.4}")).unwrap_or_default();
        for r in &self.runs {
            let acc = r.accelerations(&self.mask);
            for (h, acc) in r.hands.iter().zip(acc) {
                let _ = write!(
                    s,
                    "{},{},{},{},{},{},{}",
                    csv_field(&r.label),
                    r.mode.as_str(),
                    r.noise_px.map(|n| n.to_string()).unwrap_or_default(),
                    csv_field(&h.sequence),
                    h.frame,
                    h.side,
                    h.errors.is_some() as u8
                );
                match &h.errors {
                    Some(e) => {
                        let _ = write!(
                            s,
                            ",{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
                            metrics::masked_mean(&e.absolute, &self.mask),
                            metrics::masked_mean(&e.root_relative, &self.mask),
                            metrics::masked_mean(&e.aligned, &self.mask),
                            metrics::masked_mean(&e.procrustes, &self.mask),
                            e.axis[0],
                            e.axis[1],
                            e.axis[2]
                        );
                    }
                    None => s.push_str(",,,,,,,"),
                }
                let _ = write!(
                    s,
                    ",{},{},{:.6}",
                    opt(h.keypoints_px),
                    opt(h.reprojection_px),
                    h.seconds
                );
                for j in 0..NUM_JOINTS {
                    s.push(',');
                    // Blank where not detected or without ground truth.
                    if let Some(e) = h.errors.as_ref().filter(|e| !e.absolute[j].is_nan()) {
                        let _ = write!(s, "{:.4}", e.absolute[j]);
                    }
                }
                let _ = writeln!(
                    s,
                    ",{},{}",
                    opt(acc.map(|(pred, _)| pred)),
                    opt(h.depth_ratio)
                );
            }
        }
        s
    }

    /// Draws the report's plots into `dir` (PCK curves, errors per axis, errors over
    /// time); returns (file, caption) pairs.
    fn plots(&self, dir: &Path) -> EvalResult<Vec<(PathBuf, String)>> {
        let mut out = vec![self.pck_plot(dir)?];
        out.extend(self.axis_plot(dir)?);
        out.extend(self.time_plots(dir)?);
        Ok(out)
    }

    /// Draws `pck.png`, the PCK curves of every run (absolute per frame, aligned per
    /// joint); returns it with its caption.
    fn pck_plot(&self, dir: &Path) -> EvalResult<(PathBuf, String)> {
        let t = metrics::thresholds(0.0, 50.0, 101);
        let curve = |errors: &[f64], colour: usize, label: String| Line {
            label,
            points: t
                .iter()
                .copied()
                .zip(metrics::pck_curve(errors, &t))
                .collect(),
            colour,
            width: 2,
        };
        let mut pck_frames = Vec::new();
        let mut pck_joints = Vec::new();
        for (i, r) in self.runs.iter().enumerate() {
            let abs = r.errors(&self.mask, |e| &e.absolute);
            let al = r.errors(&self.mask, |e| &e.aligned);
            pck_frames.push(curve(&abs.frames, i, format!("{} absolute", r.label)));
            pck_joints.push(curve(&al.joints, i, format!("{} aligned", r.label)));
        }
        let pck_path = dir.join("pck.png");
        plot::draw_charts(
            &pck_path,
            &[
                Chart {
                    title: "3D PCK per frame (mean joint error, absolute)".into(),
                    x_desc: "threshold (mm)".into(),
                    y_desc: "fraction of frames".into(),
                    x: (0.0, 50.0),
                    y: (0.0, 1.0),
                    lines: pck_frames,
                },
                Chart {
                    title: "3D PCK per joint (root + scale aligned, Z&B)".into(),
                    x_desc: "threshold (mm)".into(),
                    y_desc: "fraction of joints".into(),
                    x: (0.0, 50.0),
                    y: (0.0, 1.0),
                    lines: pck_joints,
                },
            ],
            2,
            (640, 480),
        )?;
        Ok((
            pck_path,
            "3D PCK curves of every run: left, the fraction of frames whose mean absolute joint error is below the threshold (the paper's plots); right, the fraction of joints below the threshold after root and scale alignment (what STB tables integrate over 20-50 mm).".to_string(),
        ))
    }

    /// Draws `axis_errors.png`, the per-axis error per joint with one panel per run;
    /// returns it with its caption, `None` without runs.
    fn axis_plot(&self, dir: &Path) -> EvalResult<Option<(PathBuf, String)>> {
        let axis_charts: Vec<Chart> = self.runs.iter().map(|r| self.axis_chart(r)).collect();
        if axis_charts.is_empty() {
            return Ok(None);
        }
        let p = dir.join("axis_errors.png");
        plot::draw_charts(&p, &axis_charts, 2, (560, 360))?;
        Ok(Some((
            p,
            "Mean absolute error along each camera axis, per joint, for each run (z is depth)."
                .into(),
        )))
    }

    /// The mean absolute error of run `r` along each axis, per joint.
    fn axis_chart(&self, r: &RunResult) -> Chart {
        let det: Vec<_> = r
            .hands
            .iter()
            .filter_map(|h| h.pred.map(|p| (p, h.gt)))
            .collect();
        let ymax = det
            .iter()
            .flat_map(|(p, g)| {
                (0..NUM_JOINTS).flat_map(move |j| (0..3).map(move |a| (p[j][a] - g[j][a]).abs()))
            })
            .fold(0.0f64, f64::max);
        let lines = (0..3)
            .map(|a| Line {
                label: ["x", "y", "z (depth)"][a].to_string(),
                points: (0..NUM_JOINTS)
                    .filter(|&j| self.mask[j])
                    .map(|j| {
                        let v: Vec<f64> =
                            det.iter().map(|(p, g)| (p[j][a] - g[j][a]).abs()).collect();
                        (j as f64, metrics::mean(&v))
                    })
                    .collect(),
                colour: a,
                width: 2,
            })
            .collect::<Vec<_>>();
        let top = lines
            .iter()
            .flat_map(|l| l.points.iter().map(|p| p.1))
            .filter(|v| v.is_finite())
            .fold(1.0f64, f64::max)
            .min(ymax.max(1.0));
        Chart {
            title: format!("{}: mean |error| per axis", r.label),
            x_desc: "joint (0 = root ... 20 = little tip)".into(),
            y_desc: "mm".into(),
            x: (0.0, 20.0),
            y: (0.0, top * 1.1),
            lines,
        }
    }

    /// Draws the error over time, one chart per sequence (at most 12, `time_NN_SEQ.png`);
    /// returns them with their captions.
    fn time_plots(&self, dir: &Path) -> EvalResult<Vec<(PathBuf, String)>> {
        let mut out = Vec::new();
        let mut seqs: Vec<String> = Vec::new();
        for r in &self.runs {
            for h in &r.hands {
                if !seqs.contains(&h.sequence) {
                    seqs.push(h.sequence.clone());
                }
            }
        }
        for (k, seq) in seqs.iter().take(12).enumerate() {
            let name = format!("time_{k:02}_{}.png", file_safe(seq));
            let p = dir.join(&name);
            plot::draw_charts(&p, &[self.time_chart(seq)], 1, (1000, 400))?;
            out.push((
                p,
                format!("Mean absolute joint error over the frames of sequence {seq} (clipped at 200 mm)."),
            ));
        }
        Ok(out)
    }

    /// The mean absolute joint error per frame of sequence `seq`, one line per run.
    fn time_chart(&self, seq: &str) -> Chart {
        let mut lines = Vec::new();
        let mut xmax = 1.0f64;
        let mut ymax = 1.0f64;
        for (i, r) in self.runs.iter().enumerate() {
            let pts: Vec<(f64, f64)> = r
                .hands
                .iter()
                .filter(|h| h.sequence == seq)
                .filter_map(|h| {
                    h.errors.as_ref().map(|e| {
                        (
                            h.frame as f64,
                            metrics::masked_mean(&e.absolute, &self.mask),
                        )
                    })
                })
                .collect();
            for p in &pts {
                xmax = xmax.max(p.0);
                ymax = ymax.max(p.1);
            }
            lines.push(Line {
                label: r.label.clone(),
                points: pts,
                colour: i,
                width: 1,
            });
        }
        // The largest errors first, so that the smaller ones stay visible on top.
        lines.sort_by(|a, b| {
            let m = |l: &Line| metrics::mean(&l.points.iter().map(|p| p.1).collect::<Vec<_>>());
            m(b).total_cmp(&m(a))
        });
        Chart {
            title: format!("sequence {seq}: absolute error per frame"),
            x_desc: "frame".into(),
            y_desc: "mean joint error (mm)".into(),
            x: (0.0, xmax),
            y: (0.0, ymax.min(200.0) * 1.05),
            lines,
        }
    }

    /// The Markdown report; `plots` are (file, caption) pairs in `dir`.
    pub fn markdown(&self, plots: &[(PathBuf, String)]) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# monohand evaluation: {}\n", self.dataset);
        let _ = writeln!(s, "- monohand version: {}", self.version);
        let _ = writeln!(s, "- dataset: `{}`", self.source.display());
        let _ = writeln!(s, "- stage: {}", self.stage);
        let _ = writeln!(
            s,
            "- root joint: {} (root-relative and aligned errors are taken about it)",
            self.root.as_str()
        );
        let evaluated: Vec<&str> = (0..NUM_JOINTS)
            .filter(|&j| self.mask[j])
            .map(|j| {
                if j == 0 && self.root == RootJoint::PalmCentre {
                    "palm_centre"
                } else {
                    JOINT_NAMES[j]
                }
            })
            .collect();
        let _ = writeln!(
            s,
            "- evaluated joints ({}): {}",
            evaluated.len(),
            evaluated.join(", ")
        );
        for (k, v) in &self.settings {
            let _ = writeln!(s, "- {k}: {v}");
        }
        for n in &self.skeletons {
            let _ = writeln!(
                s,
                "- skeleton for {} ({} hand): hand length {:.1} mm{}",
                if n.sequence.is_empty() {
                    "all frames"
                } else {
                    &n.sequence
                },
                n.side,
                n.hand_length_mm,
                n.residual_mm
                    .map(|r| format!(", fitted to the ground truth, residual {r:.2} mm"))
                    .unwrap_or_default()
            );
        }
        let mut sources: Vec<&str> = Vec::new();
        for r in &self.runs {
            if !sources.contains(&r.source.as_str()) {
                sources.push(&r.source);
            }
        }
        for src in sources {
            let _ = writeln!(s, "- keypoints: {src}");
        }
        let _ = writeln!(
            s,
            "\nMetrics are defined in docs/evaluation.md. AUC is the normalised area under the PCK curve over {}-{} mm; \"joints\" pools every evaluated joint, \"frames\" uses each frame's mean joint error. Errors are over detected hands; the detection rate is the share of labelled hands with a fit.\n",
            AUC_RANGE_MM.0, AUC_RANGE_MM.1
        );
        s.push_str(&self.table());
        s.push_str("\nBy half of each sequence (a setting chosen here should help on both):\n\n");
        s.push_str(&self.halves_table());
        if self.root == RootJoint::PalmCentre {
            s.push_str("\nPublished STB numbers (AUC 20-50 mm, aligned, per joint; full pipeline from images on the STB test set, so not like for like with a lift-stage run on ground-truth 2D):\n\n");
            for (who, auc) in PUBLISHED_STB {
                let _ = writeln!(s, "- {who}: {auc:.3}");
            }
        }
        s.push('\n');
        for (p, caption) in plots {
            let name = p
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            let _ = writeln!(s, "![{caption}]({name})\n\n{caption}\n");
        }
        s.push_str("Raw per-hand errors: [errors.csv](errors.csv).\n");
        s
    }
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn file_safe(s: &str) -> String {
    let t: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if t.is_empty() {
        "all".into()
    } else {
        t
    }
}
