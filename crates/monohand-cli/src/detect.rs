//! `monohand detect`: hands (box, score, side, 21 keypoints) and heads in images.

use crate::progress::Terminal;
use crate::vision::ModelArgs;
use anyhow::{bail, Result};
use clap::Args;
use monohand::engine::detect::{detect_images, image_files};
use monohand::engine::{JsonlSink, Sink};
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

pub(crate) fn run(args: &DetectArgs) -> Result<()> {
    let files = image_files(&args.inputs)?;
    if args.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    let pipeline = args.models.pipeline_for(false)?;
    let out: Box<dyn Sink> = Box::new(JsonlSink::open(&args.output)?);
    let report = detect_images(
        &pipeline,
        &files,
        args.threads,
        &mut [out],
        &Terminal::without_bar(),
    )?;
    let n = report.frames;
    crate::say(&format!(
        "{n} images, {} hands, {} unreadable, {:.1} images/s",
        report.hands,
        report.unreadable,
        n as f64 / report.seconds.max(1e-9)
    ));
    if report.nothing_readable() {
        bail!("none of the {n} images could be read");
    }
    Ok(())
}
