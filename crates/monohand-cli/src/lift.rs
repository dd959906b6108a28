//! `monohand lift`: read cameras and 2D keypoints, fit, write JSON Lines. The job is the
//! library's ([`monohand::engine::lift`]); this checks the arguments and says the outcome.

use crate::LiftArgs;
use anyhow::{bail, Context, Result};
use monohand::engine::lift::{lift_keypoints, KeypointInput};
use monohand::engine::{JsonlSink, Observer, RunReport, Sink};
use monohand::HandScale;
use std::path::PathBuf;
use tracing::{info, warn};

/// The notes of the job, said with their flag; progress in the log every 100 frames.
struct Terminal;

impl Observer for Terminal {
    fn frame_written(&self, report: &RunReport) {
        if report.frames.is_multiple_of(100) {
            info!("{} frames", report.frames);
        }
    }

    fn note(&self, note: &monohand::Note) {
        crate::say(&crate::flagged(note));
    }
}

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
    let cameras = crate::read_cameras(&args.cameras)?;
    let options = args.hand.fit_options()?;
    let (scale, hand_size) = args.hand.size()?;
    let scale = match scale {
        HandScale::Fixed(s) => s,
        HandScale::Auto => {
            warn!(
                "--hand-scale auto is done by `monohand run`; `lift` keeps the default size (1.0)"
            );
            1.0
        }
    };
    let skeletons = args.hand.skeletons(scale)?;
    let mut views = Vec::with_capacity(inputs.len());
    for (i, (flag, p)) in inputs.iter().enumerate() {
        let v = if *flag == "--jsonl" {
            KeypointInput::open_jsonl(p)
        } else {
            KeypointInput::open_openpose(p)
        }
        .with_context(|| format!("2D input of view {}", i + 1))?;
        views.push(v);
    }
    let mut settings = monohand::Settings::default();
    settings.fit.skeletons = skeletons;
    settings.fit.hand_size = hand_size;
    settings.fit.options = options;
    settings.fit.tracking = args.track;
    settings.fit.proportion_frames = args.hand.proportion_frames.map(|n| n as usize);
    settings.fit.depth_filter = None;
    let settings = crate::resolve(settings)?;
    let out: Box<dyn Sink> = Box::new(
        JsonlSink::open(&args.output)?
            .with_xr_joints(args.xr_joints)
            .with_wrist_pose(args.wrist_pose),
    );
    let report = lift_keypoints(&views, cameras, &settings, &mut [out], &Terminal)?;
    if report.nothing_readable() {
        bail!(
            "none of the {} input frame(s) could be read (see the warnings above); the output has only empty frames",
            report.frames
        );
    }
    info!(
        "wrote {} frames with {} hands to {} ({} frames unreadable)",
        report.frames,
        report.hands,
        args.output.display(),
        report.unreadable
    );
    Ok(())
}
