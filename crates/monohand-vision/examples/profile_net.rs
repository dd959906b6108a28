//! Time per operator type of an imported, optimised network (where does tract spend time?).
//!
//! `cargo run --release -p monohand-vision --example profile_net -- palm_detection_full`
//! (`PER_NODE=1`: per node instead of per operator type; `PRECISION=int8`: the network as
//! `--precision int8` runs it). The runs share one tract state, as `TfliteNet::run_in` and
//! the pipeline's do; `FRESH_STATE=1` spawns one per run, as this example did until
//! 2026-11-28 (that made hand_landmark_lite 2.36 ms a run instead of 2.03-2.08 in int8,
//! one thread, and its 112x112 16->64 layer 0.36-0.41 ms instead of 0.28).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use std::collections::HashMap;
use std::time::{Duration, Instant};

use monohand_vision::{tflite_import, ModelFile, ModelStore};
use tract_core::internal::*;

fn main() -> TractResult<()> {
    let which = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "palm_detection_full".into());
    let file = ModelFile::ALL
        .into_iter()
        .find(|f| f.file_name().starts_with(&which))
        .context("unknown model")?;
    let store = ModelStore::new(None).map_err(|e| format_err!("{e}"))?;
    let bytes = store.load(file).map_err(|e| format_err!("{e}"))?;
    let precision: monohand_vision::Precision = std::env::var("PRECISION")
        .unwrap_or_else(|_| "f32".into())
        .parse()
        .map_err(|e| format_err!("{e}"))?;
    let (model, _) = monohand_vision::int8::import(
        &bytes,
        std::path::Path::new(file.file_name()),
        tflite_import::ImportOptions::default(),
        precision,
    )
    .map_err(|e| format_err!("{e}"))?;
    let model = model.into_optimized()?;
    let shape: Vec<usize> = model
        .input_fact(0)?
        .shape
        .as_concrete()
        .context("shape")?
        .to_vec();
    if std::env::var_os("SHOW_NODES").is_some() {
        for n in model.nodes() {
            if n.op().name() == std::env::var("SHOW_NODES").unwrap_or_default() {
                let facts: Vec<String> = model
                    .node_input_facts(n.id)?
                    .iter()
                    .map(|f| format!("{:?}", f.shape))
                    .collect();
                println!("{} {} inputs {:?}", n.name, n.op().name(), facts);
            }
        }
    }
    // PER_NODE=1: time per node (with its output shape) instead of per operator type.
    let per_node = std::env::var_os("PER_NODE").is_some();
    let plan = model.into_runnable()?;
    let input = Tensor::zero::<f32>(&shape)?;
    let mut per_op: HashMap<String, (Duration, usize)> = HashMap::new();
    let runs = 30;
    let t_all = Instant::now();
    let fresh = std::env::var_os("FRESH_STATE").is_some();
    let mut state = plan.spawn()?;
    for _ in 0..runs {
        if fresh {
            state = plan.spawn()?;
        }
        state.run_plan_with_eval(
            tvec!(input.clone().into_tvalue()),
            |ctx, st, node, inputs| {
                let t = Instant::now();
                let r = tract_core::plan::eval(ctx, st, node, inputs);
                let key = if per_node {
                    let facts: Vec<String> = node
                        .outputs
                        .iter()
                        .map(|o| format!("{:?}", o.fact.shape))
                        .collect();
                    format!("{} #{} -> {}", node.op().name(), node.id, facts.join(" "))
                } else {
                    node.op().name().to_string()
                };
                let e = per_op.entry(key).or_default();
                e.0 += t.elapsed();
                e.1 += 1;
                r
            },
        )?;
    }
    let total = t_all.elapsed() / runs;
    let mut v: Vec<_> = per_op.into_iter().collect();
    v.sort_by_key(|e| std::cmp::Reverse(e.1 .0));
    println!("{which}: {:.2} ms per run", total.as_secs_f64() * 1e3);
    for (name, (d, n)) in v {
        println!(
            "  {:<28} {:7.2} ms  ({} nodes)",
            name,
            d.as_secs_f64() * 1e3 / runs as f64,
            n / runs as usize
        );
    }
    Ok(())
}
