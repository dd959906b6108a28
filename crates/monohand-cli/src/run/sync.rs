//! `run --sync`: how the views of a rig are matched in time (docs/calibration.md, "Videos
//! that did not start together").

use anyhow::{bail, Result};
use monohand::core::sync::{SyncSettings, ViewOffset};
use monohand::engine::sync::{find_offsets, SYNC_FRAMES};
use monohand::engine::{Engine, FrameSource, Input};

/// What `--sync` asked for.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Sync {
    /// Frame `i` of every view together (the default).
    Index,
    /// Each view's start found from the hands.
    Auto,
    /// How late each later view started, seconds.
    Offsets(Vec<f64>),
}

impl std::str::FromStr for Sync {
    type Err = String;
    fn from_str(s: &str) -> Result<Sync, String> {
        match s {
            "index" => Ok(Sync::Index),
            "auto" => Ok(Sync::Auto),
            _ => s
                .split(',')
                .map(|x| match x.trim().parse::<f64>() {
                    Ok(v) if v.is_finite() => Ok(v),
                    _ => Err(format!(
                        "`{x}` is not a number of seconds: --sync takes index, auto, or how \
                         many seconds each later view started after the first (S2,S3,...; \
                         negative: before)"
                    )),
                })
                .collect::<Result<Vec<f64>, String>>()
                .map(Sync::Offsets),
        }
    }
}

/// The engine with the views matched as `sync` asks: with `auto`, the views of `inputs`
/// are read once more from their start to find each one's offset, and what was found is
/// said.
pub(crate) fn apply(
    sync: &Sync,
    engine: Engine,
    specs: &[String],
    inputs: &[Input],
    cameras: &[monohand::core::camera::Camera],
    sources: &[Box<dyn FrameSource>],
    stall: std::time::Duration,
) -> Result<Engine> {
    if *sync != Sync::Index && inputs.len() < 2 {
        bail!("--sync matches the views of a rig in time: it needs two or more --view");
    }
    let offsets = match sync {
        Sync::Index => return Ok(engine),
        Sync::Offsets(later) => {
            if later.len() != inputs.len() - 1 {
                bail!(
                    "--sync gives {} offset(s) for {} later view(s): one per --view after the first",
                    later.len(),
                    inputs.len() - 1
                );
            }
            std::iter::once(0.0).chain(later.iter().copied()).collect()
        }
        Sync::Auto => {
            for (v, spec) in specs.iter().enumerate() {
                let file = std::path::Path::new(spec);
                if spec.starts_with("webcam:") || !(file.is_file() || file.is_dir()) {
                    bail!(
                        "--sync auto reads each view twice (once to find its start): view {} \
                         ({spec}) is not a file or a folder that can be read again; record the \
                         cameras to files first, or give the offsets (--sync S2,S3,...)",
                        v + 1
                    );
                }
            }
            let again = inputs
                .iter()
                .map(|i| i.open(stall))
                .collect::<monohand::engine::EngineResult<Vec<_>>>()?;
            let found = find_offsets(
                engine.pipeline(),
                engine.settings(),
                cameras,
                again,
                SYNC_FRAMES,
                &SyncSettings::default(),
            )?;
            let fps = sources.first().and_then(|s| s.fps()).unwrap_or(30.0);
            say_found(&found, fps)
        }
    };
    Ok(engine.with_view_offsets(offsets))
}

/// Says each view's offset (or why it was left at 0) and how to give them again; the
/// offsets, the first view's 0 first.
fn say_found(found: &[ViewOffset], fps: f64) -> Vec<f64> {
    let mut offsets = Vec::with_capacity(found.len());
    for (v, f) in found.iter().enumerate() {
        match f {
            ViewOffset::Found(o) => {
                offsets.push(o.offset_s);
                if v == 0 {
                    continue;
                }
                let frames = o.offset_s * fps;
                let measured = o.refined_steps * o.step_s * fps;
                let when = if frames.abs() < 1e-6 {
                    "starts with view 1".to_string()
                } else {
                    let n = trim(frames.abs());
                    let s = if n == "1" { "" } else { "s" };
                    let side = if frames > 0.0 { "late" } else { "early" };
                    format!("starts {n} frame{s} {side}")
                };
                crate::say(&format!(
                    "sync: view {} {when} ({:+.4} s; measured {measured:+.2} frames; with view 1 \
                     the views agree to {:.1} px there, {:.1} px typically at other offsets, \
                     over {} frames)",
                    v + 1,
                    o.offset_s,
                    o.cost_px,
                    o.typical_px,
                    o.pairs
                ));
            }
            ViewOffset::Open(why) => {
                offsets.push(0.0);
                crate::say(&format!(
                    "sync: view {}'s start could not be found ({why}); it is taken to start with \
                     view 1",
                    v + 1
                ));
            }
        }
    }
    let list: Vec<String> = offsets.iter().skip(1).map(|o| format!("{o:.5}")).collect();
    crate::say(&format!(
        "sync: to match the views the same way again: --sync {}",
        list.join(",")
    ));
    offsets
}

/// `x` with at most 2 decimals, without trailing zeros.
fn trim(x: f64) -> String {
    let s = format!("{x:.2}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sync_takes_index_auto_or_seconds_and_refuses_anything_else() {
        assert_eq!("index".parse::<Sync>(), Ok(Sync::Index));
        assert_eq!("auto".parse::<Sync>(), Ok(Sync::Auto));
        assert_eq!(
            "0.1667,-0.1".parse::<Sync>(),
            Ok(Sync::Offsets(vec![0.1667, -0.1]))
        );
        let e = "0.1,late".parse::<Sync>().unwrap_err();
        assert!(e.contains("`late` is not a number"), "{e}");
        assert!("nan".parse::<Sync>().is_err());
        assert_eq!(trim(5.0), "5");
        assert_eq!(trim(3.5), "3.5");
    }
}
