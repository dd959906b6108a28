//! `monohand detect`: hands (box, score, side, 21 keypoints) and heads in images.

use crate::vision::ModelArgs;
use anyhow::{bail, Result};
use clap::Args;
use monohand::engine::detect::detect_images;
use monohand::engine::{JsonlSink, Observer, Sink};
use monohand_vision::image_io::images_in_folder;
use std::path::PathBuf;

/// Arguments of `monohand detect`.
#[derive(Debug, Args)]
pub(crate) struct DetectArgs {
    /// Images and/or folders of images (JPEG, PNG, WebP; a folder's images are taken in
    /// file-name order). Frames are numbered from 0 over all of them, in the order given.
    #[arg(required = true, value_name = "IMAGE|FOLDER")]
    pub inputs: Vec<PathBuf>,
    /// Where to write the detections (JSON Lines, one line per image, flushed as it goes);
    /// "-" for standard output.
    #[arg(short, long, value_name = "OUT.jsonl", default_value = "-")]
    pub output: PathBuf,
    /// Worker threads (default: all cores; 1: one core).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    #[command(flatten)]
    pub models: ModelArgs,
}

/// The image files behind the inputs, in frame order.
pub(crate) fn expand_inputs(inputs: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for input in inputs {
        if input.is_dir() {
            let found = images_in_folder(input)?;
            if found.is_empty() {
                tracing::warn!("{}: no .jpg/.jpeg/.png/.webp files", input.display());
            }
            files.extend(found);
        } else if input.exists() {
            files.push(input.clone());
        } else {
            bail!("{}: no such file or folder", input.display());
        }
    }
    Ok(files)
}

pub(crate) fn run(args: &DetectArgs) -> Result<()> {
    let files = expand_inputs(&args.inputs)?;
    if files.is_empty() {
        bail!("no images to read");
    }
    if args.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    let pipeline = args.models.pipeline(1)?;
    let out: Box<dyn Sink> = if args.output.as_os_str() == "-" {
        Box::new(JsonlSink::stdout())
    } else {
        Box::new(JsonlSink::create(&args.output)?)
    };
    let report = detect_images(&pipeline, &files, args.threads, &mut [out], &Terminal)?;
    let n = report.frames;
    crate::say(&format!(
        "{n} images, {} hands, {} unreadable, {:.1} images/s",
        report.hands,
        report.unreadable,
        n as f64 / report.seconds.max(1e-9)
    ));
    if report.unreadable > 0 && report.unreadable == n {
        bail!("none of the {n} images could be read");
    }
    Ok(())
}

/// Ctrl-C stops the job after the images in flight.
struct Terminal;

impl Observer for Terminal {
    fn cancelled(&self) -> bool {
        crate::interrupted()
    }
}
