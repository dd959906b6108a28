//! Time per operator type of a `.tflite` network imported by this crate and optimised by
//! tract, one thread unless `MONOHAND_OP_THREADS` says otherwise (the share of 1x1, depthwise,
//! first-layer convolution and the rest):
//!
//! `MONOHAND_OP_THREADS=1 cargo run --release -p monohand-tflite --example profile_ops -- \
//!  ~/.cache/monohand/models/hand_landmark_full.tflite [runs]`
//!
//! `INT8=crates/monohand-vision/int8/hand_landmark_full.txt` first swaps every 1x1 layer the
//! calibration table names for its int8 version ([`monohand_tflite::quantize_pointwise`];
//! the table's lines are `name min_bits max_bits # ...`, its checksum is not checked here);
//! with `UNCODED=1` too, each int8 layer codes its own f32 input (no
//! [`monohand_tflite::NhwcDepthwiseCodes`]), to compare.
//!
//! `PER_NODE=1` times each node (with its first input's and its output's shapes) instead of each operator type.
//! (monohand-vision's `profile_net` does the same through the model store; this one needs
//! only this crate.) The input is a constant 0.5 image; timing one node at a time adds a
//! little overhead per node, so the total is a little above a plain run's.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed measurement is a panic

use std::collections::HashMap;
use std::time::{Duration, Instant};

use tract_core::internal::*;

fn main() -> TractResult<()> {
    let path = std::env::args()
        .nth(1)
        .context("usage: profile_ops MODEL.tflite [runs]")?;
    let runs: usize = std::env::args()
        .nth(2)
        .map(|r| r.parse())
        .transpose()?
        .unwrap_or(50);
    let model = load(&path)?;
    let model = model.into_optimized()?;
    let shape: Vec<usize> = model
        .input_fact(0)?
        .shape
        .as_concrete()
        .context("shape")?
        .to_vec();
    let per_node = std::env::var_os("PER_NODE").is_some();
    let plan = model.into_runnable()?;
    let input = tract_ndarray::ArrayD::from_elem(shape, 0.5f32).into_tensor();
    let mut per_op: HashMap<String, (Duration, usize)> = HashMap::new();
    let mut state = plan.spawn()?;
    // Warm up (weights into cache, the helper team started).
    for _ in 0..5 {
        state.run(tvec!(input.clone().into_tvalue()))?;
    }
    let mut plain = Duration::MAX;
    for _ in 0..runs {
        let t = Instant::now();
        state.run(tvec!(input.clone().into_tvalue()))?;
        plain = plain.min(t.elapsed());
    }
    let t_all = Instant::now();
    for _ in 0..runs {
        state.run_plan_with_eval(
            tvec!(input.clone().into_tvalue()),
            |ctx, st, node, inputs| {
                let input = inputs.first().map(|i| format!("{:?}", i.shape()));
                let t = Instant::now();
                let r = tract_core::plan::eval(ctx, st, node, inputs);
                let key = if per_node {
                    let facts: Vec<String> = node
                        .outputs
                        .iter()
                        .map(|o| format!("{:?}", o.fact.shape))
                        .collect();
                    format!(
                        "{} #{} {} -> {}",
                        node.op().name(),
                        node.id,
                        input.unwrap_or_default(),
                        facts.join(" ")
                    )
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
    let total = t_all.elapsed() / runs as u32;
    let mut v: Vec<_> = per_op.into_iter().collect();
    v.sort_by_key(|e| std::cmp::Reverse(e.1 .0));
    let sum: f64 = v.iter().map(|e| e.1 .0.as_secs_f64()).sum::<f64>() / runs as f64;
    println!(
        "{path}: best plain run {:.2} ms; timed per node {:.2} ms per run (nodes sum {:.2} ms)",
        plain.as_secs_f64() * 1e3,
        total.as_secs_f64() * 1e3,
        sum * 1e3
    );
    for (name, (d, n)) in v {
        let ms = d.as_secs_f64() * 1e3 / runs as f64;
        println!(
            "  {:<60} {:7.3} ms {:5.1} %  ({} nodes)",
            name,
            ms,
            100.0 * ms / (sum * 1e3),
            n / runs
        );
    }
    Ok(())
}

/// The model at `path`, its 1x1 layers in int8 where `INT8` names a calibration table.
fn load(path: &str) -> TractResult<TypedModel> {
    let bytes = std::fs::read(path)?;
    let mut model = monohand_tflite::import(&bytes).map_err(|e| format_err!("{e}"))?;
    if let Some(table) = std::env::var_os("INT8") {
        let ranges = read_table(&std::fs::read_to_string(table)?)?;
        let n = if std::env::var_os("UNCODED").is_some() {
            // Each 1x1 layer codes its own f32 input (the int8 layers alone, without
            // `code_depthwise_results`), to compare.
            let mut n = 0;
            for id in 0..model.nodes().len() {
                let node = model.node(id);
                if let (Some(op), Some(r)) = (
                    node.op_as::<monohand_tflite::PointwiseConv>(),
                    ranges.get(&node.name),
                ) {
                    model.node_mut(id).op = Box::new(op.to_int8(r.quant())?);
                    n += 1;
                }
            }
            n
        } else {
            monohand_tflite::quantize_pointwise(&mut model, &ranges, |_, _| false)?
        };
        println!("int8: {n} of {} 1x1 layers in the table", ranges.len());
    }
    Ok(model)
}

/// The ranges of a calibration table (monohand-vision's `Int8Table` format, read simply).
fn read_table(text: &str) -> TractResult<HashMap<String, monohand_tflite::MinMax>> {
    let bits = |s: &str| u32::from_str_radix(s, 16).map(f32::from_bits);
    let mut ranges = HashMap::new();
    for line in text.lines().skip(3) {
        let parts: Vec<&str> = line
            .split('#')
            .next()
            .unwrap_or("")
            .split_whitespace()
            .collect();
        if let [name, lo, hi] = parts[..] {
            let (min, max) = (bits(lo)?, bits(hi)?);
            ranges.insert(name.to_owned(), monohand_tflite::MinMax { min, max });
        }
    }
    Ok(ranges)
}
