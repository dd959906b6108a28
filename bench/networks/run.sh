#!/usr/bin/env bash
# The four hand networks (palm and landmark, full and lite), monohand (tract with its own
# operators, loaded through TfliteNet, 1 thread) against LiteRT 2.3 (XNNPACK, 1 thread),
# interleaved on the same input; also monohand in int8 (its shipped calibration, the 1x1
# convolutions in int8) and other variants (`--variants`). Prints the CPU model and flags and a table of ms and ratios.
# Not part of .ci/run (it installs ai-edge-litert from PyPI). See docs/performance.md.
#
# Usage: bench/networks/run.sh [--rounds N] [--runs N] [--threads N] [--variants LIST]
#   --rounds N       interleaved rounds (default 5)
#   --runs N         timed inferences per round, network and runtime (default 20)
#   --threads N      threads for both runtimes (default 1): LiteRT's num_threads, and
#                    monohand's operators sharing their rows (MONOHAND_OP_THREADS)
#   --variants LIST  extra monohand variants, comma-separated, each a '+'-joined list of
#                    int8, no-pointwise, no-epilogue, no-depthwise, no-prelu, no-dw-act,
#                    no-dw-blocking, no-conv, no-split, no-resize, no-pool
#                    (default int8)
# Environment: MODELS (default ~/.cache/monohand/models), CARGO_TARGET_DIR (default target),
#   VENV (default /tmp/monohand-litert-venv), PYTHON (default python3).
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$root/target}
MODELS=${MODELS:-$HOME/.cache/monohand/models}
VENV=${VENV:-/tmp/monohand-litert-venv}
PYTHON=${PYTHON:-python3}

for f in palm_detection_full palm_detection_lite hand_landmark_full hand_landmark_lite; do
    [ -f "$MODELS/$f.tflite" ] || { echo "missing $MODELS/$f.tflite (run monohand once to fetch the models, or set MODELS)" >&2; exit 1; }
done
if [ ! -x "$VENV/bin/python" ]; then
    "$PYTHON" -m venv "$VENV"
    "$VENV/bin/pip" install -q ai-edge-litert==2.3.0 numpy pillow
fi
cargo build --release -q -p monohand-vision --example net_timer
exec "$VENV/bin/python" bench/networks/run.py \
    --timer "$CARGO_TARGET_DIR/release/examples/net_timer" \
    --models "$MODELS" \
    --fixtures crates/monohand-vision/tests/fixtures "$@"
