//! Which sinks `monohand run` writes to, from its arguments: the poses (JSON Lines, CSV or
//! OpenPose JSON), the overlay, the glTF, the Rerun recording, the LeRobot dataset and the
//! live window.

use super::RunArgs;
use anyhow::{anyhow, Result};
use clap::ValueEnum;
use monohand::engine::{
    CsvSink, GltfSink, JsonlSink, LeRobotSink, OpenPoseSink, OverlaySink, Sink, WindowSink,
};
use monohand_io::export::GltfHand;
use monohand_media::scene::Layers;
use std::path::Path;

/// Format of the poses file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum OutputFormat {
    /// JSON Lines, one record per frame (docs/output-format.md).
    Jsonl,
    /// CSV, one row per hand per frame, with a header.
    Csv,
    /// OpenPose JSON, one `{stem}_{frame:012}_keypoints.json` per frame in the --output
    /// folder, with `hand_*_keypoints_2d` and `hand_*_keypoints_3d`.
    Openpose,
}

/// How the glTF draws each hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum GltfStyle {
    /// A real hand mesh (the WebXR generic hand) skinned to the fitted joints.
    Skinned,
    /// The 21 joints and 20 bones as small solids.
    Joints,
}

/// The sinks of a run, in the order they are written: poses, glTF, Rerun, window, overlay
/// (nothing is created if an argument is wrong). `single_image`: the input is one image
/// (the only case an image-file overlay takes, and a window then stays open at the end).
pub(crate) fn create(
    args: &RunArgs,
    fps: Option<f64>,
    single_image: bool,
) -> Result<Vec<Box<dyn Sink>>> {
    let show = match args.show {
        true => Some(
            WindowSink::open(
                "monohand",
                Layers::only(&args.layers),
                single_image,
                crate::stop_flag(),
            )
            .map_err(|e| anyhow!("--show {e}"))?,
        ),
        false => None,
    };
    let overlay = match &args.overlay {
        None => None,
        Some(p) => Some(
            OverlaySink::create(
                p,
                fps.unwrap_or(30.0),
                single_image,
                Layers::only(&args.layers),
            )
            .map_err(|e| anyhow!("--overlay {e}"))?,
        ),
    };
    let rerun = args.rerun.as_ref().map(|p| rerun(args, p)).transpose()?;
    let poses: Box<dyn Sink> = match args.format {
        OutputFormat::Jsonl => {
            let sink = JsonlSink::open(&args.output)?
                .with_xr_joints(args.xr_joints)
                .with_wrist_pose(args.wrist_pose);
            Box::new(sink)
        }
        OutputFormat::Csv => Box::new(CsvSink::open(&args.output)?),
        OutputFormat::Openpose => {
            if args.output.as_os_str() == "-" {
                anyhow::bail!(
                    "--format openpose writes one file per frame: give a folder as --output"
                );
            }
            let stem = args
                .input
                .as_deref()
                .or(args.views.first().map(String::as_str))
                .and_then(|i| Path::new(i).file_stem())
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "monohand".into());
            Box::new(
                OpenPoseSink::create(&args.output, &stem).map_err(|e| anyhow!("--output {e}"))?,
            )
        }
    };
    let mut sinks = vec![poses];
    if let Some(p) = &args.gltf {
        let hand = match args.gltf_hand {
            GltfStyle::Skinned => GltfHand::Skinned,
            GltfStyle::Joints => GltfHand::Joints,
        };
        let gltf = GltfSink::create(p, hand).map_err(|e| anyhow!("--gltf {}: {e}", p.display()))?;
        sinks.push(Box::new(gltf));
    }
    if let Some(r) = rerun {
        sinks.push(r);
    }
    if let Some(dir) = &args.lerobot {
        let views = args.input.iter().chain(&args.views).count().max(1);
        let source = args
            .input
            .as_deref()
            .or(args.views.first().map(String::as_str))
            .map(Path::new);
        let sink = LeRobotSink::create(dir, views, fps.unwrap_or(30.0), &args.lerobot_task)
            .map_err(|e| anyhow!("--lerobot {e}"))?
            .with_source(source);
        sinks.push(Box::new(sink));
    }
    if let Some(show) = show {
        sinks.push(Box::new(show));
    }
    if let Some(o) = overlay {
        sinks.push(Box::new(o));
    }
    Ok(sinks)
}

/// Each view's name in a Rerun recording: its camera file's stem (else its input's), made
/// unique with the view's number.
fn view_names(args: &RunArgs) -> Vec<String> {
    let inputs: Vec<&str> = args
        .input
        .iter()
        .chain(&args.views)
        .map(String::as_str)
        .collect();
    let stem = |p: &Path| p.file_stem().map(|s| s.to_string_lossy().into_owned());
    let mut names: Vec<String> = (0..inputs.len().max(args.cameras.len()))
        .map(|v| {
            let from_camera = args.cameras.get(v).and_then(|c| stem(c));
            let from_input = inputs.get(v).and_then(|i| stem(Path::new(i)));
            from_camera
                .or(from_input)
                .unwrap_or_else(|| format!("view{}", v + 1))
        })
        .collect();
    for v in 0..names.len() {
        if names[..v].contains(&names[v]) || names[v + 1..].contains(&names[v]) {
            names[v] = format!("{}_{}", names[v], v + 1);
        }
    }
    names
}

/// The Rerun sink of `--rerun`.
#[cfg(feature = "rerun")]
fn rerun(args: &RunArgs, path: &Path) -> Result<Box<dyn Sink>> {
    let sink = monohand::engine::RerunSink::create(path, view_names(args), args.rerun_image_scale)
        .map_err(|e| anyhow!("--rerun {}: {e}", path.display()))?;
    Ok(Box::new(sink))
}

/// Without the `rerun` feature, `--rerun` says how to get it.
#[cfg(not(feature = "rerun"))]
fn rerun(args: &RunArgs, path: &Path) -> Result<Box<dyn Sink>> {
    let _ = view_names(args);
    anyhow::bail!(
        "--rerun {}: this monohand was built without Rerun recordings; build it with \
         `cargo build --release -p monohand-cli --features rerun` (docs/visualisation.md)",
        path.display()
    )
}
