//! The lifting job: 2D keypoint files made elsewhere (OpenPose folders, the project's JSON
//! Lines) of one or several calibrated views in, 3D hands out to the engine's sinks.

use super::{EngineResult, InputError, Observer, Output, RunReport, Sink, Writer};
use crate::lifter::Lifter;
use crate::stages::fitter::fit::{learn_proportions, FitOutcome};
use monohand_core::observation::NetworkCues;
use monohand_core::prelude::*;
use monohand_io::jsonl::{read_jsonl, FrameRecord, HandRecord};
use monohand_io::openpose::{list_openpose_files, read_openpose_file};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use tracing::{debug, warn};

/// The 2D keypoints of one view, frame by frame.
#[derive(Debug)]
pub enum KeypointInput {
    /// OpenPose JSON files, one per frame (file-name order).
    OpenPose(Vec<PathBuf>),
    /// The project's JSON Lines (`monohand detect` or `run` output), by frame index.
    Jsonl {
        /// The file, for messages.
        path: PathBuf,
        /// Its records by frame index.
        frames: BTreeMap<u64, FrameRecord>,
    },
}

impl KeypointInput {
    /// An OpenPose folder (or one file).
    pub fn open_openpose(path: &Path) -> EngineResult<KeypointInput> {
        let files = list_openpose_files(path).map_err(|e| InputError::Keypoints(e.to_string()))?;
        Ok(KeypointInput::OpenPose(files))
    }

    /// A JSON Lines file; a frame index that appears twice is refused.
    pub fn open_jsonl(path: &Path) -> EngineResult<KeypointInput> {
        let mut frames = BTreeMap::new();
        for rec in read_jsonl(path).map_err(|e| InputError::Keypoints(e.to_string()))? {
            let i = rec.frame;
            if frames.insert(i, rec).is_some() {
                return Err(InputError::Keypoints(format!(
                    "{}: frame {i} appears more than once",
                    path.display()
                ))
                .into());
            }
        }
        Ok(KeypointInput::Jsonl {
            path: path.to_path_buf(),
            frames,
        })
    }

    /// Frames: files, or the last frame index + 1.
    pub fn len(&self) -> usize {
        match self {
            KeypointInput::OpenPose(files) => files.len(),
            KeypointInput::Jsonl { frames, .. } => frames
                .keys()
                .next_back()
                .map_or(0, |&last| last as usize + 1),
        }
    }

    /// Whether there is no frame.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn source_name(&self, i: usize) -> Option<String> {
        match self {
            KeypointInput::OpenPose(files) => files
                .get(i)
                .and_then(|p| p.file_name())
                .map(|n| n.to_string_lossy().to_string()),
            KeypointInput::Jsonl { frames, .. } => {
                frames.get(&(i as u64)).and_then(|r| r.source.clone())
            }
        }
    }

    /// The hands of frame `i` (none for a frame the input lacks), or why it is unreadable.
    pub fn frame(&self, i: usize) -> Result<Vec<HandObservation>, KeypointError> {
        match self {
            KeypointInput::OpenPose(files) => match files.get(i) {
                None => Ok(Vec::new()),
                Some(p) => Ok(read_openpose_file(p)?.hands),
            },
            KeypointInput::Jsonl { path, frames } => {
                let Some(rec) = frames.get(&(i as u64)) else {
                    return Ok(Vec::new());
                };
                let mut hands = Vec::new();
                for (h, hand) in rec.hands.iter().enumerate() {
                    let bad = |field, source| KeypointError::Hand {
                        path: path.clone(),
                        frame: i,
                        hand: h,
                        field,
                        source,
                    };
                    let keypoints = hand.keypoints().map_err(|e| bad(".keypoints_2d", e))?;
                    let cues = hand.cues().map_err(|e| bad("", e))?;
                    if !keypoints.is_empty() {
                        hands.push(HandObservation {
                            side: hand.side,
                            keypoints,
                            cues,
                        });
                    }
                }
                Ok(hands)
            }
        }
    }
}

/// Why a frame of 2D keypoints could not be read (it is written without hands).
#[derive(Debug, thiserror::Error)]
pub enum KeypointError {
    /// An OpenPose file that could not be read.
    #[error(transparent)]
    OpenPose(#[from] monohand_io::IoError),
    /// A hand of a JSON Lines record with impossible keypoints or cues.
    #[error("{}: frame {frame} hands[{hand}]{field}: {source}", path.display())]
    Hand {
        /// The file.
        path: PathBuf,
        /// The frame, from 0.
        frame: usize,
        /// The hand within it.
        hand: usize,
        /// Which of its fields (`.keypoints_2d`; empty: its cues).
        field: &'static str,
        /// Why.
        source: monohand_core::CoreError,
    },
}

/// Lifts every frame of `inputs` (one per view, matched by index) with `cameras` (one per
/// view, the first the reference) into `sinks`, and closes them. Frames a view cannot read
/// are written without hands ([`RunReport::unreadable`]); hands that cannot be fitted are
/// left out, with a warning. The fit is `settings`' ([`crate::ResolvedSettings::lifting`]:
/// the skeletons, the fitter's options, tracking and the proportions learnt; what needs the
/// images is refused).
pub fn lift_keypoints(
    inputs: &[KeypointInput],
    cameras: Vec<Camera>,
    settings: &crate::ResolvedSettings,
    sinks: &mut [Box<dyn Sink>],
    observer: &dyn Observer,
) -> EngineResult<RunReport> {
    if inputs.is_empty() || inputs.len() != cameras.len() {
        return Err(InputError::CameraCount {
            cameras: cameras.len(),
            views: inputs.len(),
            what: " of keypoints",
            per: "camera",
            order: "",
        }
        .into());
    }
    let settings = settings.lifting()?;
    for note in crate::stages::cameras::calibration_notes(&cameras) {
        observer.note(&note);
    }
    let mut skeletons = settings.skeletons;
    if let Some(n) = settings.proportion_frames {
        for (skeleton, side) in skeletons.iter_mut().zip([HandSide::Left, HandSide::Right]) {
            let cues: Vec<NetworkCues> = (0..n.min(inputs[0].len()))
                .filter_map(|i| inputs[0].frame(i).ok())
                .flatten()
                .filter(|h| h.side == side)
                .filter_map(|h| h.cues)
                .collect();
            if cues.is_empty() {
                continue;
            }
            let (learnt, note) = learn_proportions(skeleton, side, &cues);
            observer.note(&note);
            if let Some(est) = learnt {
                *skeleton = est.skeleton;
            }
        }
    }
    let mut lifter = Lifter::new(cameras, skeletons, settings.options, settings.tracking)?;
    let lens: Vec<usize> = inputs.iter().map(KeypointInput::len).collect();
    let n_frames = lens.iter().copied().max().unwrap_or(0);
    if lens.iter().any(|&l| l != n_frames) {
        warn!(
            "views have different frame counts {lens:?}; frames are matched by index and a view without frame i contributes nothing to it"
        );
    }
    let mut out = Writer::new(sinks, observer);
    let mut warned_multi = false;
    let mut result = Ok(());
    for i in 0..n_frames {
        if observer.cancelled() {
            break;
        }
        let mut per_view = Vec::with_capacity(inputs.len());
        let mut failed = None;
        for (v, input) in inputs.iter().enumerate() {
            match input.frame(i) {
                Ok(f) => per_view.push(f),
                Err(msg) => {
                    warn!(
                        "frame {i}: view {} unreadable, frame written with no hands: {msg}",
                        v + 1
                    );
                    failed = Some(msg);
                }
            }
        }
        let record = if failed.is_some() {
            out.report.unreadable += 1;
            FrameRecord {
                frame: i as u64,
                source: inputs[0].source_name(i),
                ..FrameRecord::default()
            }
        } else {
            lift_frame(
                i,
                inputs[0].source_name(i),
                &per_view,
                &mut lifter,
                &mut warned_multi,
            )
        };
        result = out.write(&Output {
            record: &record,
            image: None,
            cameras: &[],
            other_images: &[],
            fitted: None,
        });
        if result.is_err() {
            break;
        }
    }
    out.end(result)
}

/// The record of frame `i`, its views' hands lifted (`per_view[v]`: view `v`'s hands).
fn lift_frame(
    i: usize,
    source: Option<String>,
    per_view: &[Vec<HandObservation>],
    lifter: &mut Lifter,
    warned_multi: &mut bool,
) -> FrameRecord {
    let mut record = FrameRecord {
        frame: i as u64,
        source,
        ..FrameRecord::default()
    };
    let hands: Vec<&[HandObservation]> = per_view.iter().map(Vec::as_slice).collect();
    for lifted in lifter.lift(&hands) {
        let side = lifted.side;
        if let Some(&(v, count)) = lifted.crowded_views.first().filter(|_| !*warned_multi) {
            warn!(
                "frame {i}: view {} has {count} {side} hands; using the most confident one per view (several people are not supported; further such warnings suppressed)",
                v + 1
            );
            *warned_multi = true;
        }
        // The first view's keypoints (all zero when only other views see the hand).
        let first_view_kp = lifted
            .views
            .iter()
            .find(|&&(v, _)| v == 0)
            .and_then(|&(_, k)| hands.first()?.get(k))
            .map(|h| h.keypoints)
            .unwrap_or_default();
        match lifted.outcome {
            FitOutcome::Fitted(fit) => {
                debug!(
                    "frame {i}: {side} hand in {} view(s), {:.2} px, {} iterations",
                    lifted.views.len(),
                    fit.reprojection_error_px,
                    fit.iterations
                );
                record
                    .hands
                    .push(HandRecord::from_fit(side, &first_view_kp, &fit));
            }
            FitOutcome::Diverged => {
                warn!("frame {i}: {side} hand: the fit diverged (non-finite result), skipped");
            }
            FitOutcome::Failed(CoreError::TooFewJoints {
                usable,
                threshold,
                needed,
            }) => warn!(
                "frame {i}: {side} hand skipped: {usable} usable joint observation(s) with confidence >= {threshold}, need at least {needed}"
            ),
            FitOutcome::Failed(e) => warn!("frame {i}: {side} hand skipped: {e}"),
        }
    }
    record
}
