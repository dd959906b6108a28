//! `run --each DIR --output-dir OUT`: every video and image of a folder as its own input,
//! each into `OUT/<file name>.jsonl`, complete or absent ([`monohand::engine::corpus`]).

use super::{settings, stall_timeout, Outcome, RunArgs};
use crate::progress::Terminal;
use anyhow::{bail, Result};
use monohand::engine::corpus::{corpus, CorpusItem, Ended};
use monohand::engine::{Engine, EngineError, Input};
use monohand::HandPipeline;
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

pub(super) fn run(args: &RunArgs, dir: &Path, out: &Path) -> Result<Outcome> {
    if args.cameras.len() > 1 {
        bail!("--each runs one view per input: give at most one --camera");
    }
    let cameras = crate::read_cameras(&args.cameras)?;
    let stall = stall_timeout(args)?;
    let mut items = corpus(dir, out)?;
    if args.lerobot.is_some() {
        items = items
            .into_iter()
            .map(|i| i.with_episode(&args.lerobot_task))
            .collect();
    }
    // The networks, loaded once per kind of input (tracked videos, independent images).
    let mut pipelines: HashMap<bool, Arc<HandPipeline>> = HashMap::new();
    let (mut done, mut skipped, mut failed) = (0, 0, 0);
    for item in &items {
        let name = item.input.display();
        if item.is_done() {
            skipped += 1;
            crate::say(&format!("{name}: already done, skipped"));
            continue;
        }
        let ended = match one(args, item, &cameras, stall, &mut pipelines) {
            Ok(ended) => ended,
            Err(e) => {
                if matches!(e.downcast_ref(), Some(EngineError::Output { .. })) {
                    crate::say(&format!(
                        "{name}: stopped, its output could not be written; the {} complete \
                         outputs in {} are kept, and a rerun goes on from them",
                        done + skipped,
                        out.display()
                    ));
                }
                return Err(e);
            }
        };
        match ended {
            Ended::Done => {
                done += 1;
                crate::say(&format!("{name}: done, {}", item.output.display()));
            }
            Ended::Failed(why) => {
                failed += 1;
                crate::say(&format!("{name}: failed: {why}"));
            }
            Ended::Cancelled => {
                crate::say(&format!("{name}: interrupted; a rerun redoes it"));
                dataset(args, &items)?;
                return Ok(Outcome::Interrupted);
            }
        }
    }
    crate::say(&format!(
        "{} inputs: {done} done, {skipped} already done, {failed} failed",
        items.len()
    ));
    dataset(args, &items)?;
    Ok(if failed > 0 {
        Outcome::InputEndedEarly
    } else {
        Outcome::Complete
    })
}

/// With `--lerobot DS`: the episodes of the inputs done so far, as one dataset at `DS`
/// (made again from all of them at each end of the job, a rerun's included).
fn dataset(args: &RunArgs, items: &[CorpusItem]) -> Result<()> {
    let Some(ds) = &args.lerobot else {
        return Ok(());
    };
    let parts: Vec<std::path::PathBuf> = items
        .iter()
        .filter(|i| i.is_done())
        .filter_map(|i| i.episode.as_ref().map(|e| e.dir.clone()))
        .collect();
    if parts.is_empty() {
        crate::say(&format!(
            "--lerobot {}: no input done, no dataset",
            ds.display()
        ));
        return Ok(());
    }
    let made = monohand_io::lerobot::assemble(&parts, ds)
        .map_err(|e| anyhow::anyhow!("--lerobot {}: {e}", ds.display()))?;
    for (part, why) in &made.left_out {
        crate::say(&format!("--lerobot: {} left out: {why}", part.display()));
    }
    crate::say(&format!(
        "--lerobot {}: {} episodes, {} frames",
        ds.display(),
        made.episodes,
        made.frames
    ));
    Ok(())
}

/// Runs one input into its partial file and, if it ended well, renames it. Errors that
/// concern the job (an output that cannot be written, bad settings) stop it.
fn one(
    args: &RunArgs,
    item: &CorpusItem,
    cameras: &[monohand_core::camera::Camera],
    stall: std::time::Duration,
    pipelines: &mut HashMap<bool, Arc<HandPipeline>>,
) -> Result<Ended> {
    let input = Input::parse(&item.input.to_string_lossy())?;
    // The settings are checked as for a video; --offline and --smooth apply to the videos.
    let settings = crate::resolve(settings(args, true)?)?;
    let settings = if (input.is_video() || args.track) && !args.no_track {
        settings
    } else {
        settings.untracked()
    };
    let source = match input.open(stall) {
        Ok(s) => s,
        Err(e) => return Ok(Ended::Failed(e.to_string())),
    };
    let tracking = settings.tracking();
    let pipeline = match pipelines.get(&tracking) {
        Some(p) => Arc::clone(p),
        None => {
            let p = Arc::new(args.models.pipeline(settings.pipeline())?);
            pipelines.insert(tracking, Arc::clone(&p));
            p
        }
    };
    let engine = Engine::new(pipeline, cameras.to_vec(), settings)?;
    let terminal = Terminal {
        progress: crate::progress::Progress::new(source.len_hint()),
    };
    let ended = item.run(&engine, source, &terminal)?;
    terminal.progress.finish();
    Ok(ended)
}
