//! The detection job: image files in, each image's hands (box, score, side, 21 keypoints,
//! the network's 3D cues) and heads out to the engine's sinks, without 3D fitting. The
//! images are independent, so the networks run on all cores, a chunk at a time, and the
//! records are written in order.

use super::{
    thread_pool, EngineResult, Input, InputError, Observer, Output, RunReport, Sink, Writer,
};
use crate::stages::records::detections_record;
use monohand_io::jsonl::FrameRecord;
use monohand_vision::HandPipeline;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The image files behind `inputs` (images and folders of images, each read as
/// [`Input::parse`] reads it), in frame order; a video is refused.
pub fn image_files(inputs: &[PathBuf]) -> EngineResult<Vec<PathBuf>> {
    let mut files = Vec::new();
    for input in inputs {
        match Input::parse(&input.to_string_lossy())? {
            Input::Images(found) => files.extend(found),
            Input::Video(_) => {
                return Err(InputError::NotImages {
                    path: input.clone(),
                }
                .into())
            }
        }
    }
    Ok(files)
}

/// Detects the hands of every image in `files` (in order) into `sinks`, and closes them.
/// An unreadable image gets a record with its error; `threads` as in
/// [`crate::Settings::threads`].
pub fn detect_images(
    pipeline: &HandPipeline,
    files: &[PathBuf],
    threads: Option<usize>,
    sinks: &mut [Box<dyn Sink>],
    observer: &dyn Observer,
) -> EngineResult<RunReport> {
    let pool = thread_pool(threads)?;
    let chunk = 4 * pool.current_num_threads();
    let mut out = Writer::new(sinks, observer);
    let mut detect_all = || -> EngineResult<()> {
        for (c, paths) in files.chunks(chunk).enumerate() {
            if observer.cancelled() {
                tracing::warn!("interrupted: stopped after {} images", c * chunk);
                break;
            }
            let records: Vec<FrameRecord> = pool.install(|| {
                paths
                    .par_iter()
                    .enumerate()
                    .map(|(k, path)| detect_one(pipeline, (c * chunk + k) as u64, path))
                    .collect()
            });
            for record in &records {
                if let Some(e) = &record.error {
                    tracing::warn!("frame {}: {e}", record.frame);
                }
                out.write(&Output {
                    record,
                    image: None,
                    cameras: &[],
                    other_images: &[],
                    fitted: None,
                })?;
            }
        }
        Ok(())
    };
    let result = detect_all();
    out.end(result)
}

/// The record of one image: its detections, with the time they took, or why it could not
/// be read.
fn detect_one(pipeline: &HandPipeline, frame: u64, path: &Path) -> FrameRecord {
    let source = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string());
    let t = Instant::now();
    match pipeline.detect_file(path) {
        Ok(found) => {
            let mut r = detections_record(frame, Some(source), &found);
            r.timings_ms = Some([("total".to_string(), t.elapsed().as_secs_f64() * 1e3)].into());
            r
        }
        Err(e) => FrameRecord {
            frame,
            source: Some(source),
            error: Some(e.to_string()),
            ..FrameRecord::default()
        },
    }
}
