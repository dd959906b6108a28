//! `monohand lift`: read cameras and 2D keypoints, fit, write JSON Lines.

use crate::hand_args::HandScale;
use crate::LiftArgs;
use anyhow::{bail, Context, Result};
use monohand::{FitOutcome, Lifter};
use monohand_core::fitting::estimate_proportions;
use monohand_core::observation::NetworkCues;
use monohand_core::prelude::*;
use monohand_io::jsonl::{read_jsonl, FrameRecord, HandRecord, JsonlWriter};
use monohand_io::openpose::{list_openpose_files, read_openpose_file};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use tracing::{debug, info, warn};

/// The 2D input of one view.
enum ViewInput {
    /// One OpenPose file per frame.
    OpenPose(Vec<PathBuf>),
    /// JSON Lines records by frame index.
    Jsonl {
        path: PathBuf,
        frames: BTreeMap<u64, FrameRecord>,
    },
}

/// What one view says about one frame.
struct ViewFrame {
    hands: Vec<HandObservation>,
}

impl ViewInput {
    fn open_openpose(path: &Path) -> Result<ViewInput> {
        Ok(ViewInput::OpenPose(list_openpose_files(path)?))
    }

    fn open_jsonl(path: &Path) -> Result<ViewInput> {
        let mut frames = BTreeMap::new();
        for rec in read_jsonl(path)? {
            let i = rec.frame;
            if frames.insert(i, rec).is_some() {
                bail!("{}: frame {i} appears more than once", path.display());
            }
        }
        Ok(ViewInput::Jsonl {
            path: path.to_path_buf(),
            frames,
        })
    }

    fn len(&self) -> usize {
        match self {
            ViewInput::OpenPose(files) => files.len(),
            ViewInput::Jsonl { frames, .. } => frames
                .keys()
                .next_back()
                .map_or(0, |&last| last as usize + 1),
        }
    }

    /// The name of the input of frame `i`, if known (even if it cannot be read).
    fn source_name(&self, i: usize) -> Option<String> {
        match self {
            ViewInput::OpenPose(files) => files
                .get(i)
                .and_then(|p| p.file_name())
                .map(|n| n.to_string_lossy().to_string()),
            ViewInput::Jsonl { frames, .. } => {
                frames.get(&(i as u64)).and_then(|r| r.source.clone())
            }
        }
    }

    /// The hands of frame `i`; `Err` (a message) if the frame cannot be read.
    fn frame(&self, i: usize) -> Result<ViewFrame, String> {
        match self {
            ViewInput::OpenPose(files) => match files.get(i) {
                None => Ok(ViewFrame { hands: Vec::new() }),
                Some(p) => read_openpose_file(p)
                    .map(|f| ViewFrame { hands: f.hands })
                    .map_err(|e| e.to_string()),
            },
            ViewInput::Jsonl { path, frames } => {
                let Some(rec) = frames.get(&(i as u64)) else {
                    return Ok(ViewFrame { hands: Vec::new() });
                };
                let mut hands = Vec::new();
                for (h, hand) in rec.hands.iter().enumerate() {
                    let keypoints = hand.keypoints().map_err(|e| {
                        format!("{}: frame {i} hands[{h}].keypoints_2d: {e}", path.display())
                    })?;
                    let cues = hand
                        .cues()
                        .map_err(|e| format!("{}: frame {i} hands[{h}]: {e}", path.display()))?;
                    if !keypoints.is_empty() {
                        hands.push(HandObservation {
                            side: hand.side,
                            keypoints,
                            cues,
                        });
                    }
                }
                Ok(ViewFrame { hands })
            }
        }
    }
}

/// `--proportion-frames`: each side's proportions from the network's metric 3D
/// (`world_mm`) of its hands in the first `n` frames of the first view, applied to that
/// side's skeleton; says what it found.
fn learn_proportions(view: &ViewInput, n: usize, skeletons: &mut [HandSkeleton; 2]) {
    for (skeleton, side) in skeletons.iter_mut().zip([HandSide::Left, HandSide::Right]) {
        let cues: Vec<NetworkCues> = (0..n.min(view.len()))
            .filter_map(|i| view.frame(i).ok())
            .flat_map(|f| f.hands.into_iter())
            .filter(|h| h.side == side)
            .filter_map(|h| h.cues)
            .collect();
        if cues.is_empty() {
            continue;
        }
        match estimate_proportions(skeleton, &cues) {
            Ok(est) => {
                crate::say(&format!(
                    "--proportion-frames: {side} hand proportions {est}"
                ));
                *skeleton = est.skeleton;
            }
            Err(e) => warn!(
                "--proportion-frames: {side} hand proportions not learnt ({e}); keeping the model's"
            ),
        }
    }
}

/// The hand of this side in a view: the one with the largest total confidence (the first
/// of equals).
pub(crate) fn run(args: &LiftArgs) -> Result<()> {
    // Everything that can be checked is checked before the output is created.
    let inputs: Vec<(&str, &PathBuf)> = if args.jsonl.is_empty() {
        args.openpose.iter().map(|p| ("--openpose", p)).collect()
    } else {
        args.jsonl.iter().map(|p| ("--jsonl", p)).collect()
    };
    if inputs.is_empty() {
        bail!("no 2D input: give one --openpose (or --jsonl) per --camera");
    }
    if inputs.len() != args.cameras.len() {
        bail!(
            "view count mismatch: {} --camera but {} {}; give exactly one camera per view, in the same order",
            args.cameras.len(),
            inputs.len(),
            inputs[0].0
        );
    }
    let mut cameras = Vec::with_capacity(args.cameras.len());
    for (i, p) in args.cameras.iter().enumerate() {
        let cam = monohand_io::calibration::read_camera(p)
            .with_context(|| format!("camera of view {}", i + 1))?;
        if i == 0 && !cam.extrinsics.is_identity() {
            warn!(
                "{}: the first camera has extrinsics; output joints are in the frame they map from, not in this camera's frame",
                p.display()
            );
        }
        cameras.push(cam);
    }
    let options = args.hand.fit_options()?;
    let scale = match args.hand.hand_scale {
        HandScale::Fixed(s) => s,
        HandScale::Auto => {
            warn!(
                "--hand-scale auto is done by `monohand run`; `lift` keeps the default size (1.0)"
            );
            1.0
        }
    };
    let mut skeletons = [
        args.hand.skeleton(HandSide::Left, scale)?,
        args.hand.skeleton(HandSide::Right, scale)?,
    ];
    let mut views_in = Vec::with_capacity(inputs.len());
    for (i, (flag, p)) in inputs.iter().enumerate() {
        let v = if *flag == "--jsonl" {
            ViewInput::open_jsonl(p)
        } else {
            ViewInput::open_openpose(p)
        }
        .with_context(|| format!("2D input of view {}", i + 1))?;
        views_in.push(v);
    }
    if let Some(n) = args.hand.proportion_frames {
        learn_proportions(&views_in[0], n as usize, &mut skeletons);
    }
    let mut lifter = Lifter::new(cameras, skeletons, options, args.track)?;
    let lens: Vec<usize> = views_in.iter().map(ViewInput::len).collect();
    let n_frames = lens.iter().copied().max().unwrap_or(0);
    if lens.iter().any(|&l| l != n_frames) {
        warn!(
            "views have different frame counts {lens:?}; frames are matched by index and a view without frame i contributes nothing to it"
        );
    }

    let mut writer = if args.output.as_os_str() == "-" {
        JsonlWriter::stdout()
    } else {
        JsonlWriter::create(&args.output)?
    };

    let (mut hands_written, mut skipped, mut unreadable) = (0usize, 0usize, 0usize);
    let mut warned_multi = false;
    for i in 0..n_frames {
        let mut per_view = Vec::with_capacity(views_in.len());
        let mut failed = false;
        for (v, input) in views_in.iter().enumerate() {
            match input.frame(i) {
                Ok(f) => per_view.push(f),
                Err(msg) => {
                    warn!(
                        "frame {i}: view {} unreadable, frame written with no hands: {msg}",
                        v + 1
                    );
                    failed = true;
                }
            }
        }
        let mut record = FrameRecord {
            frame: i as u64,
            source: views_in[0].source_name(i),
            ..FrameRecord::default()
        };
        if failed {
            unreadable += 1;
            writer.write_frame(&record)?;
            continue;
        }
        let hands: Vec<&[HandObservation]> = per_view.iter().map(|f| f.hands.as_slice()).collect();
        for lifted in lifter.lift(&hands) {
            let side = lifted.side;
            if let Some(&(v, count)) = lifted.crowded_views.first().filter(|_| !warned_multi) {
                warn!(
                    "frame {i}: view {} has {count} {side} hands; using the most confident one per view (several people are not supported; further such warnings suppressed)",
                    v + 1
                );
                warned_multi = true;
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
                    skipped += 1;
                }
                FitOutcome::Failed(CoreError::TooFewJoints {
                    usable,
                    threshold,
                    needed,
                }) => {
                    warn!(
                        "frame {i}: {side} hand skipped: {usable} usable joint observation(s) with confidence >= {threshold}, need at least {needed}"
                    );
                    skipped += 1;
                }
                FitOutcome::Failed(e) => {
                    warn!("frame {i}: {side} hand skipped: {e}");
                    skipped += 1;
                }
            }
        }
        hands_written += record.hands.len();
        writer.write_frame(&record)?;
        if (i + 1) % 100 == 0 {
            info!("{} / {n_frames} frames", i + 1);
        }
    }
    if n_frames > 0 && unreadable == n_frames {
        bail!("none of the {n_frames} input frame(s) could be read (see the warnings above); the output has only empty frames");
    }
    info!(
        "wrote {} frames with {hands_written} hands to {} ({skipped} hands skipped, {unreadable} frames unreadable)",
        writer.frames_written(),
        args.output.display()
    );
    Ok(())
}
