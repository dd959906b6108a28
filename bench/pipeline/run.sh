#!/usr/bin/env bash
# MediaPipe's own Python hand pipeline (mediapipe==0.10.14, legacy solutions.hands) against
# `monohand run` on the same video: frames per second of each, their ratio, monohand's time
# per stage, and the 2D disagreement between the two sets of keypoints.
# Not part of .ci/run (it installs MediaPipe from PyPI and takes minutes). See
# docs/performance.md.
#
# Usage: bench/pipeline/run.sh [--rounds N] [--frames N] [--cpus LIST] [--codec C]
#                              [--size WxH[,WxH...]] [--baseline BIN]
#   --rounds N   alternating rounds (default 3); fps are the median over rounds
#   --frames N   length of the video (default 300, 640x480 at 30 fps)
#   --cpus LIST  run both tools under `taskset -c LIST` (default: no pinning, whole machine)
#   --codec C    ffv1 (default: lossless RGB, both tools read identical pixels; version 3
#                with 4 slices, so the decoder can use both cores), ffv1-1slice (the same
#                pixels in one slice, as measured until 2026-11-24: its decoding takes one
#                core, 7.6-8.7 ms per frame) or h264 (CRF 18, as cameras write: 1.6 ms per frame)
#   --size LIST  frame sizes, e.g. 640x480,1920x1080,3840x2160: the clip is scaled to each
#                with ffmpeg, and `bench.py sizes` runs MediaPipe (max_num_hands=1), monohand
#                like for like and monohand with its defaults at each size, alternating
#                (one table: $OUT/sizes.md). The size bench of docs/performance.md is
#                  bench/pipeline/run.sh --codec h264 --frames 150 --rounds 3 \
#                      --size 640x480,1280x720,1920x1080,3840x2160 --baseline MAIN_BIN
#   --baseline BIN  with --size: a second monohand binary (e.g. main's), run alike ("before")
# Environment: PHOTO (default ../shared/data/images/pinto/hand.png beside the repo),
#   OUT (default target/pipeline-bench), CARGO_TARGET_DIR (default target), PYTHON (the
#   interpreter that creates the virtual environment, default python3; MediaPipe 0.10.14
#   has wheels for CPython 3.8 to 3.12).
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
rounds=3 frames=300 cpus="" codec=ffv1 sizes="" baseline=""
while [ $# -gt 0 ]; do
    case "$1" in
        --rounds) rounds=$2; shift 2 ;;
        --frames) frames=$2; shift 2 ;;
        --cpus) cpus=$2; shift 2 ;;
        --codec) codec=$2; shift 2 ;;
        --size) sizes=$2; shift 2 ;;
        --baseline) baseline=$2; shift 2 ;;
        *) echo "unknown option $1 (see the header of $0)" >&2; exit 2 ;;
    esac
done
PHOTO=${PHOTO:-$root/../shared/data/images/pinto/hand.png}
OUT=${OUT:-$root/target/pipeline-bench}
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$root/target}
PYTHON=${PYTHON:-python3}
venv=$root/bench/pipeline/.venv

[ -f "$PHOTO" ] || { echo "photo not found: $PHOTO (set PHOTO)" >&2; exit 1; }
command -v ffmpeg >/dev/null || { echo "ffmpeg not found (apt-get install ffmpeg)" >&2; exit 1; }
mkdir -p "$OUT"

echo "== machine" >&2
lscpu | grep -E '^(Model name|CPU\(s\)|Thread|Core|Socket)' >&2 || true
uptime >&2

if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c 'import mediapipe' 2>/dev/null; then
    echo "== virtual environment $venv (mediapipe==0.10.14)" >&2
    "$PYTHON" -m venv "$venv"
    "$venv/bin/pip" install --quiet --upgrade pip
    "$venv/bin/pip" install --quiet mediapipe==0.10.14
fi
"$venv/bin/python" -c 'import sys, mediapipe, cv2, numpy; print("python", sys.version.split()[0], "mediapipe", mediapipe.__version__, "opencv", cv2.__version__, "numpy", numpy.__version__)' >&2

echo "== build monohand (release)" >&2
cargo build --release --locked -p monohand-cli
monohand=$CARGO_TARGET_DIR/release/monohand
"$monohand" models fetch >&2
"$monohand" --version >&2 || true

case "$codec" in
    ffv1) video=$OUT/moving_${frames}_ffv1_4slices.mkv ;;
    ffv1-1slice) video=$OUT/moving_${frames}.mkv ;;
    h264) video=$OUT/moving_${frames}_h264.mp4 ;;
    *) echo "unknown codec $codec (ffv1, ffv1-1slice or h264)" >&2; exit 2 ;;
esac
if [ ! -f "$video" ]; then
    echo "== video $video" >&2
    "$venv/bin/python" bench/pipeline/make_video.py "$PHOTO" "$video" --frames "$frames" --codec "$codec" >&2
fi

if [ -n "$sizes" ]; then
    videos=()
    for size in ${sizes//,/ }; do
        scaled=${video%.*}_$size.${video##*.}
        if [ ! -f "$scaled" ]; then
            echo "== video $scaled" >&2
            "$venv/bin/python" bench/pipeline/make_video.py "$PHOTO" "$scaled" --frames "$frames" \
                --codec "$codec" --size "$size" >&2
        fi
        videos+=("$scaled")
    done
    echo "== run ($rounds rounds per size)" >&2
    "$venv/bin/python" bench/pipeline/bench.py sizes "${videos[@]}" --monohand "$monohand" \
        ${baseline:+--baseline "$baseline"} --rounds "$rounds" --out "$OUT" ${cpus:+--cpus "$cpus"}
    echo "== wrote $OUT/sizes.md, $OUT/sizes.json" >&2
    exit 0
fi

echo "== run ($rounds rounds)" >&2
"$venv/bin/python" bench/pipeline/bench.py compare "$video" --monohand "$monohand" \
    --rounds "$rounds" --out "$OUT" ${cpus:+--cpus "$cpus"}
echo "== wrote $OUT/report.md, $OUT/results.json" >&2
