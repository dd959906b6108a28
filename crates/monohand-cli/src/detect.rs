//! `monohand detect`: hands (box, score, side, 21 keypoints) and heads in images.

use crate::vision::ModelArgs;
use anyhow::{bail, Result};
use clap::Args;
use monohand::records::detections_record;
use monohand_io::jsonl::{FrameRecord, JsonlWriter};
use monohand_vision::image_io::images_in_folder;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

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

fn source_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

pub(crate) fn run(args: &DetectArgs) -> Result<()> {
    let files = expand_inputs(&args.inputs)?;
    if files.is_empty() {
        bail!("no images to read");
    }
    let pipeline = args.models.pipeline(1)?;
    let mut writer = if args.output.as_os_str() == "-" {
        JsonlWriter::stdout()
    } else {
        JsonlWriter::create(&args.output)?
    };
    let pool = crate::thread_pool(args.threads)?;
    let chunk = 4 * pool.current_num_threads();
    let start = Instant::now();
    let (mut hands, mut failed) = (0usize, 0usize);
    for (c, paths) in files.chunks(chunk).enumerate() {
        if crate::interrupted() {
            tracing::warn!("interrupted: stopped after {} images", c * chunk);
            break;
        }
        let records: Vec<FrameRecord> = pool.install(|| {
            paths
                .par_iter()
                .enumerate()
                .map(|(k, path)| {
                    let frame = (c * chunk + k) as u64;
                    let t = Instant::now();
                    match pipeline.detect_file(path) {
                        Ok(found) => {
                            let mut r = detections_record(frame, Some(source_name(path)), &found);
                            r.timings_ms = Some(
                                [("total".to_string(), t.elapsed().as_secs_f64() * 1e3)].into(),
                            );
                            r
                        }
                        Err(e) => FrameRecord {
                            frame,
                            source: Some(source_name(path)),
                            error: Some(e.to_string()),
                            ..FrameRecord::default()
                        },
                    }
                })
                .collect()
        });
        for r in &records {
            if let Some(e) = &r.error {
                tracing::warn!("frame {}: {e}", r.frame);
                failed += 1;
            }
            hands += r.hands.len();
            writer.write_frame(r)?;
        }
    }
    let n = writer.frames_written();
    let secs = start.elapsed().as_secs_f64();
    crate::say(&format!(
        "{n} images, {hands} hands, {failed} unreadable, {:.1} images/s",
        n as f64 / secs.max(1e-9)
    ));
    if failed > 0 && failed == n {
        bail!("none of the {n} images could be read");
    }
    Ok(())
}
