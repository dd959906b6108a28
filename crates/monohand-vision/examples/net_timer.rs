//! Times networks loaded through [`TfliteNet`], driven line by line on stdin so that
//! `bench/networks/run.py` can interleave it with LiteRT in the same session. The operators
//! share their rows between `MONOHAND_OP_THREADS` threads (`run.py` sets it: 1 unless
//! `--threads`).
//!
//! Commands (one per line, one answer line each):
//! * `load NAME MODEL.tflite INPUT.f32 OPTIONS`: imports the model; `INPUT.f32` holds the
//!   input as raw little-endian f32 (NHWC); `OPTIONS` is `default` or a comma-separated
//!   list among `no-pointwise`, `no-epilogue`, `no-depthwise`, `no-prelu`, `no-dw-act`, `no-dw-blocking`,
//!   `no-conv`, `no-split`, `no-resize`, `no-pool`
//!   (switching monohand's own operators back to tract's), and `int8` (the network's
//!   shipped int8 calibration: its 1x1 and first convolutions in int8). Answers `ok`.
//! * `time NAME RUNS`: runs the network `RUNS` times on a reused run state, as the pipeline
//!   does (the input is copied into the state's buffer before each timed run, like LiteRT's
//!   `set_tensor` before `invoke`; only the run is timed); answers the milliseconds of each
//!   run, space separated.
//! * `output NAME`: answers the first values of each output (to check both runtimes agree).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed bench is a panic

use std::collections::HashMap;
use std::io::{BufRead, Write};
use std::path::Path;
use std::time::Instant;

use monohand_vision::tflite_import::ImportOptions;
use monohand_vision::{NetState, Precision, TfliteNet};
use tract_core::internal::*;

fn main() {
    let mut nets: HashMap<String, (TfliteNet, Tensor, NetState)> = HashMap::new();
    let stdin = std::io::stdin();
    let mut out = std::io::stdout().lock();
    for line in stdin.lock().lines() {
        let line = line.expect("stdin");
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["load", name, model, input, options] => {
                let mut o = ImportOptions::default();
                let mut precision = Precision::F32;
                for opt in options.split(',') {
                    match opt {
                        "default" => {}
                        "int8" => precision = Precision::Int8,
                        "no-pointwise" => o.fast_pointwise = false,
                        "no-epilogue" => o.fused_pointwise_epilogue = false,
                        "no-depthwise" => o.fast_depthwise = false,
                        "no-prelu" => o.fused_prelu = false,
                        "no-dw-act" => o.fused_depthwise_activation = false,
                        "no-dw-blocking" => o.register_blocked_depthwise = false,
                        "no-conv" => o.fast_conv = false,
                        "no-split" => o.split_rows = false,
                        "no-resize" => o.fast_resize = false,
                        "no-pool" => o.fast_pool = false,
                        other => panic!("unknown option {other}"),
                    }
                }
                let bytes = std::fs::read(model).expect("model");
                let net = TfliteNet::from_bytes_in(&bytes, Path::new(model), o, precision)
                    .expect("import");
                let raw = std::fs::read(input).expect("input");
                let values: Vec<f32> = raw
                    .chunks_exact(4)
                    .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                    .collect();
                let x = Tensor::from_shape(&net.input_shape(), &values).expect("input shape");
                net.run(x.clone()).expect("warm-up run");
                let mut state = net.new_state().expect("run state");
                net.run_in(&mut state, |buf| buf.copy_from_slice(&values), |_| Ok(()))
                    .expect("warm-up run in the state");
                nets.insert(name.to_string(), (net, x, state));
                writeln!(out, "ok").expect("stdout");
            }
            ["time", name, runs] => {
                let (net, x, state) = nets.get_mut(*name).expect("a loaded network");
                let values = x
                    .try_as_plain_ram()
                    .and_then(|r| r.as_slice::<f32>())
                    .expect("f32 input");
                let runs: usize = runs.parse().expect("runs");
                let ms: Vec<String> = (0..runs)
                    .map(|_| {
                        let mut t = Instant::now();
                        net.run_in(
                            state,
                            |buf| {
                                buf.copy_from_slice(values);
                                t = Instant::now();
                            },
                            |out| {
                                std::hint::black_box(out.len());
                                Ok(())
                            },
                        )
                        .expect("run");
                        format!("{:.4}", t.elapsed().as_secs_f64() * 1e3)
                    })
                    .collect();
                writeln!(out, "{}", ms.join(" ")).expect("stdout");
            }
            ["output", name] => {
                let (net, x, _) = &nets[*name];
                let outs = net.run(x.clone()).expect("run");
                let heads: Vec<String> = outs
                    .iter()
                    .map(|o| {
                        o.iter()
                            .take(8)
                            .map(|v| format!("{v}"))
                            .collect::<Vec<_>>()
                            .join(",")
                    })
                    .collect();
                writeln!(out, "{}", heads.join(" ")).expect("stdout");
            }
            _ => panic!("unknown command: {line}"),
        }
        out.flush().expect("stdout");
    }
}
