//! `--stage full`: each sequence run through the engine of `monohand run` as the video it
//! is, and its records scored.
//!
//! - Each sequence is one input per view ([`monohand::engine::FrameSource`]), its frames in
//!   order, so that when the fit tracks ([`EvalSettings::fit`]) the engine tracks as `run` does on a video
//!   (crops from the last keypoints, fits from the last pose, a palm detection every
//!   [`DETECT_EVERY`] frames); without it every frame is detected and fitted on its own.
//! - A sequence whose images are crops of larger frames ([`Frame::crop`], the hand-graph-cnn
//!   set) is pasted back into black frames of the original camera, as
//!   `tools/dev_video.py` does, so the engine sees one camera for the whole sequence.
//! - Of several hands of a labelled hand's side in a record, the one with the highest mean
//!   keypoint confidence is scored. 2D errors are in the pixels of the dataset's images.

use crate::dataset::{CropOrigin, Dataset, Frame};
use crate::error::{EvalError, EvalResult};
use crate::evaluate::{
    check_settings, empty_runs, evaluated_joints, mean_px, palm_centre_estimate, skeletons,
    EvalSettings, HandResult, RunResult, SkeletonChoice, SkeletonNote, ViewMode,
};
use crate::metrics::{self, HandErrors, Joints};
use monohand::engine::{
    Engine, FrameSource, Output, Quiet, Sink, SinkError, SourceError, SourceFrame,
};
use monohand::{HandPipeline, RgbImage};
use monohand_core::prelude::*;
use monohand_io::jsonl::{FrameRecord, HandRecord};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// While tracking, the engine looks for new hands every this many frames (`run`'s default).
pub const DETECT_EVERY: usize = 10;

/// The frame rate given to the sequences (their frames' times are `index / FPS`).
const FPS: f64 = 30.0;

/// Runs every mode of `settings` over the dataset through the engine with `pipeline`
/// (`description` names its networks in the report).
pub fn evaluate_full(
    dataset: &Dataset,
    pipeline: &Arc<HandPipeline>,
    description: &str,
    settings: &EvalSettings,
) -> EvalResult<(Vec<RunResult>, Vec<SkeletonNote>)> {
    check_settings(dataset, settings)?;
    if let Some(f) = dataset
        .frames
        .iter()
        .find(|f| f.images.len() != f.cameras.len())
    {
        return Err(EvalError::Detector(format!(
            "frame {} of sequence {:?} has no image for every camera (the full stage needs images)",
            f.index, f.sequence
        )));
    }
    let (sks, notes) = skeletons(dataset, settings)?;
    let source = format!("the engine of `monohand run`: {description}");
    let (mut runs, mut network) = empty_runs(settings, &source, None);
    let mask = evaluated_joints(dataset.root);
    let palm_root = dataset.root == crate::dataset::RootJoint::PalmCentre
        && settings.skeleton == SkeletonChoice::Default;
    for seq in sequences(dataset) {
        let sides = [HandSide::Left, HandSide::Right].map(|side| {
            sks.get(&(seq[0].sequence.clone(), side))
                .copied()
                .map_or_else(
                    || HandSkeleton::default_for(side).scaled(settings.hand_scale),
                    Ok,
                )
        });
        let [left, right] = sides;
        let skeletons = [
            left.map_err(|e| EvalError::core("--hand-scale", e))?,
            right.map_err(|e| EvalError::core("--hand-scale", e))?,
        ];
        for (m, run) in runs.iter_mut().enumerate() {
            let (records, seconds) = run_sequence(seq, run.mode, pipeline, settings, skeletons)?;
            let per_frame = seconds / seq.len().max(1) as f64;
            for (frame, record) in seq.iter().zip(&records) {
                if let Some(e) = &record.error {
                    return Err(EvalError::Detector(format!(
                        "{}: {e}",
                        frame.images[0].display()
                    )));
                }
                let per_hand = per_frame / frame.hands.len().max(1) as f64;
                for h in 0..frame.hands.len() {
                    let found = matching_hand(record, frame, h);
                    let scored = Scored {
                        frame,
                        h,
                        found,
                        seconds: per_hand,
                    };
                    run.hands.push(scored.fit(&mask, palm_root));
                    if m == 0 {
                        network.hands.push(scored.network(&mask));
                    }
                }
            }
        }
    }
    if network.hands.iter().any(|h| h.pred.is_some()) {
        runs.push(network);
    }
    Ok((runs, notes))
}

/// The dataset's sequences: runs of consecutive frames of one sequence name.
fn sequences(dataset: &Dataset) -> Vec<&[Frame]> {
    let mut out = Vec::new();
    let mut rest = dataset.frames.as_slice();
    while let Some(first) = rest.first() {
        let n = rest
            .iter()
            .take_while(|f| f.sequence == first.sequence)
            .count();
        let (seq, tail) = rest.split_at(n);
        out.push(seq);
        rest = tail;
    }
    out
}

/// The camera the engine sees for view `v` of a frame: the original frame's for a crop.
fn engine_camera(frame: &Frame, v: usize) -> Camera {
    match (&frame.crop, v) {
        (Some(c), 0) => c.camera,
        _ => frame.cameras[v],
    }
}

/// One sequence in one view mode through the engine: its records, one per frame, and the
/// run's wall-clock seconds.
fn run_sequence(
    seq: &[Frame],
    mode: ViewMode,
    pipeline: &Arc<HandPipeline>,
    settings: &EvalSettings,
    skeletons: [HandSkeleton; 2],
) -> EvalResult<(Vec<FrameRecord>, f64)> {
    let views = match mode {
        ViewMode::Mono => 1,
        ViewMode::Stereo => seq[0].cameras.len(),
    };
    let cameras: Vec<Camera> = (0..views).map(|v| engine_camera(&seq[0], v)).collect();
    for f in seq {
        if f.cameras.len() < views || (0..views).any(|v| engine_camera(f, v) != cameras[v]) {
            return Err(EvalError::Settings(format!(
                "--stage full runs each sequence as one video, so all its frames need the same \
                 cameras; frame {} of sequence {:?} has others",
                f.index, f.sequence
            )));
        }
    }
    // The networks as loaded: the engine checks them against these settings.
    let engine_settings = settings.resolve(skeletons, pipeline.options, DETECT_EVERY)?;
    let engine = Engine::new(Arc::clone(pipeline), cameras, engine_settings)
        .map_err(|e| EvalError::Detector(e.to_string()))?;
    let sources: Vec<Box<dyn FrameSource>> = (0..views)
        .map(|v| {
            Box::new(SequenceImages {
                images: seq
                    .iter()
                    .map(|f| (f.images[v].clone(), if v == 0 { f.crop } else { None }))
                    .collect(),
                next: 0,
                video: settings.fit.tracking,
            }) as Box<dyn FrameSource>
        })
        .collect();
    let records = Arc::new(Mutex::new(Vec::with_capacity(seq.len())));
    let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(Keep(Arc::clone(&records)))];
    let report = engine
        .run(sources, &mut sinks, &Quiet)
        .map_err(|e| EvalError::Detector(monohand::engine::chain(&e)))?;
    drop(sinks);
    let records = Arc::try_unwrap(records)
        .map_err(|_| EvalError::Detector("the engine kept its sink".into()))?
        .into_inner()
        .map_err(|_| EvalError::Detector("a sink failed".into()))?;
    if records.len() != seq.len() {
        return Err(EvalError::Detector(format!(
            "sequence {:?}: {} records for {} frames{}",
            seq[0].sequence,
            records.len(),
            seq.len(),
            report
                .input_error
                .map(|e| format!(" ({e})"))
                .unwrap_or_default()
        )));
    }
    Ok((records, report.seconds))
}

/// The images of one view of a sequence, crops pasted back into their frames.
struct SequenceImages {
    images: Vec<(PathBuf, Option<CropOrigin>)>,
    next: usize,
    video: bool,
}

impl FrameSource for SequenceImages {
    fn next_frame(&mut self) -> Result<Option<SourceFrame>, SourceError> {
        let Some((path, crop)) = self.images.get(self.next) else {
            return Ok(None);
        };
        let index = self.next as u64;
        self.next += 1;
        let image = monohand::vision::image_io::load_rgb(path)
            .map_err(|e| SourceError::Image(e.to_string()))
            .and_then(|img| match crop {
                Some(c) => uncrop(&img, c),
                None => Ok(img),
            });
        Ok(Some(SourceFrame {
            index,
            source: Some(path.display().to_string()),
            timestamp_s: index as f64 / FPS,
            image,
            decode_ms: 0.0,
            focal: monohand::StatedCamera::None,
        }))
    }

    fn is_video(&self) -> bool {
        self.video
    }

    fn len_hint(&self) -> Option<u64> {
        Some(self.images.len() as u64)
    }
}

/// A crop resized to its box and pasted into a black frame of the original camera's size
/// (bicubic, as ffmpeg's default scaler in `tools/dev_video.py`).
fn uncrop(crop: &RgbImage, origin: &CropOrigin) -> Result<RgbImage, SourceError> {
    let k = &origin.camera.intrinsics;
    let [x, y, w, h] = origin.box_xywh.map(f64::round);
    if !(w >= 1.0 && h >= 1.0 && x.is_finite() && y.is_finite()) {
        return Err(SourceError::Image(format!(
            "crop box {:?} is empty",
            origin.box_xywh
        )));
    }
    let scaled = image::imageops::resize(
        crop,
        w as u32,
        h as u32,
        image::imageops::FilterType::CatmullRom,
    );
    let mut frame = RgbImage::new(k.width, k.height);
    image::imageops::overlay(&mut frame, &scaled, x as i64, y as i64);
    Ok(frame)
}

/// Keeps the records.
struct Keep(Arc<Mutex<Vec<FrameRecord>>>);

impl Sink for Keep {
    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError> {
        self.0
            .lock()
            .map_err(|_| "poisoned")?
            .push(frame.record.clone());
        Ok(())
    }
}

/// The record's hand that is labelled hand `h` of `frame`: of those whose keypoints in the
/// first view lie within [`MATCH_PX`] of its 2D labels (or its 3D labels projected) on
/// average, the nearest, whatever side the network gave it (a hand given the wrong side
/// is fitted with the other side's skeleton, which its errors then show). Where none does,
/// the most confident hand of the labelled side.
fn matching_hand<'a>(record: &'a FrameRecord, frame: &Frame, h: usize) -> Option<&'a HandRecord> {
    let gt = frame.gt_keypoints(h, 0);
    let apart = |rec: &HandRecord| {
        let mut points = rec.keypoints_2d;
        if let Some(c) = &frame.crop {
            for p in points.iter_mut() {
                (p[0], p[1]) = c.to_crop(p[0], p[1]);
            }
        }
        mean_px(&metrics::keypoint_errors_px(&points, &gt.points)).filter(|&d| d <= MATCH_PX)
    };
    let nearest = record
        .hands
        .iter()
        .filter_map(|r| Some((apart(r)?, r)))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, r)| r);
    let conf = |r: &HandRecord| r.keypoints_2d.iter().map(|p| p[2]).sum::<f64>();
    let side = frame.hands[h].side;
    nearest.or_else(|| {
        record
            .hands
            .iter()
            .filter(|r| r.side == side)
            .max_by(|a, b| conf(a).total_cmp(&conf(b)))
    })
}

/// The largest mean distance (pixels of the dataset's images) between a found hand's
/// keypoints and a labelled hand's 2D for the two to be taken as one hand: a hand's
/// width at its smallest in these sets (80 px), so that a neighbour's hand is never taken.
const MATCH_PX: f64 = 60.0;

/// Labelled hand `h` of `frame` and what the engine found of its side.
struct Scored<'a> {
    frame: &'a Frame,
    h: usize,
    found: Option<&'a HandRecord>,
    seconds: f64,
}

impl Scored<'_> {
    /// Mean 2D error of the found keypoints in the first view, in the dataset image's pixels.
    fn keypoints_px(&self) -> Option<f64> {
        let found = self.found?;
        let mut points = found.keypoints_2d;
        if let Some(c) = &self.frame.crop {
            for p in points.iter_mut() {
                (p[0], p[1]) = c.to_crop(p[0], p[1]);
            }
        }
        let gt = self.frame.gt_keypoints(self.h, 0);
        mean_px(&metrics::keypoint_errors_px(&points, &gt.points))
    }

    fn result(
        &self,
        pred: Option<Joints>,
        reprojection_px: Option<f64>,
        mask: &metrics::JointMask,
    ) -> HandResult {
        let hand = &self.frame.hands[self.h];
        HandResult {
            sequence: self.frame.sequence.clone(),
            frame: self.frame.index,
            side: hand.side,
            errors: pred.map(|p| HandErrors::compute(&p, &hand.joints_3d, mask, 0)),
            pred,
            gt: hand.joints_3d,
            keypoints_px: self.keypoints_px(),
            reprojection_px,
            depth_ratio: pred.and_then(|p| {
                metrics::depth_ratio(&p, &hand.joints_3d, mask, &self.frame.cameras[0])
            }),
            seconds: self.seconds,
        }
    }

    /// The fitted hand's result (`palm_root`: put the palm centre in joint 0).
    fn fit(&self, mask: &metrics::JointMask, palm_root: bool) -> HandResult {
        let pred = self.found.and_then(|f| f.joints_3d()).map(|j| {
            let mut out = metrics::to_joints(&j);
            if palm_root {
                out[0] = palm_centre_estimate(&j);
            }
            out
        });
        let reprojection_px = pred.as_ref().and_then(|p| {
            let k = crate::dataset::project_joints(&self.frame.cameras[0], p);
            let gt = self.frame.gt_keypoints(self.h, 0);
            mean_px(&metrics::keypoint_errors_px(&k.points, &gt.points))
        });
        self.result(pred, reprojection_px, mask)
    }

    /// The network's own 3D of the hand, placed at the ground truth's centroid.
    fn network(&self, mask: &metrics::JointMask) -> HandResult {
        let gt = &self.frame.hands[self.h].joints_3d;
        let pred = self.found.and_then(|f| f.world_mm).map(|w| {
            let labelled = metrics::labelled(gt, mask);
            let (cw, cg) = (
                metrics::centroid(&w, &labelled),
                metrics::centroid(gt, &labelled),
            );
            w.map(|p| std::array::from_fn(|k| p[k] - cw[k] + cg[k]))
        });
        HandResult {
            depth_ratio: None,
            ..self.result(pred, None, mask)
        }
    }
}
