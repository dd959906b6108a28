#!/usr/bin/env bash
# Soak benchmark: an hour of 30 fps video through `monohand run` with tracking, the depth
# overlay video and the glTF export on, the resident memory sampled every few seconds.
# Not part of .ci/run (it takes most of an hour). Results: docs/performance.md, "Soak".
#
# Usage: bench/soak/run.sh [--minutes M] [--size WxH] [--segment S] [--every S] [--video-only]
#   --minutes M  length of the video (default 60)
#   --size WxH   frame size (default 320x240: the same frame count as an hour at full size
#                but cheaper to decode and encode; the networks' crops are the same size)
#   --segment S  seconds of each photo's clip (default M*60/6: each photo once); shorter
#                clips are made once and their sequence repeated (stream copy) up to M
#                minutes, which makes a long video in a fraction of the encoding time
#   --every S    memory sampling period in seconds (default 5)
#   --video-only make the video (if it is not there yet), print its path and stop
#                (bench/python/corpus_memory.py uses it)
# Environment: OUT (default target/soak), CARGO_TARGET_DIR (default target), SHARED (default
#   ../shared beside the repository).
#
# The video: six segments of M/6 minutes, each a photo from $SHARED/data/images (a hand, two
# hands, a hand held up, a crop, and a photo without a hand) seen by a camera that pans
# slowly (ffmpeg's crop with time expressions), so tracking, losing and finding hands
# again, and the palm detector all run.
#
# Pass (bench/soak/report.py prints it, exit 1 if not): frames out = frames in, every JSON
# Lines record parses, and the resident memory grows by less than 5% from the 10th minute
# (one sixth of the way in, for shorter runs) to the end, net of the glTF writer's stated
# 256 bytes per hand per frame (the raw growth is printed beside it).
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
minutes=60 size=320x240 every=5 video_only= segment=
while [ $# -gt 0 ]; do
    case "$1" in
        --minutes) minutes=$2; shift 2 ;;
        --size) size=$2; shift 2 ;;
        --every) every=$2; shift 2 ;;
        --segment) segment=$2; shift 2 ;;
        --video-only) video_only=1; shift ;;
        *) echo "unknown option $1 (see the header of $0)" >&2; exit 2 ;;
    esac
done
SHARED=${SHARED:-$root/../shared}
OUT=${OUT:-$root/target/soak}
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$root/target}
command -v ffmpeg >/dev/null || { echo "ffmpeg not found (apt-get install ffmpeg)" >&2; exit 1; }
mkdir -p "$OUT"
w=${size%x*} h=${size#*x}

photos=(
    "$SHARED/data/images/pinto/hand.png"
    "$SHARED/data/images/hamer/test1.jpg"
    "$SHARED/data/images/hamer/test3.jpg"
    "$SHARED/data/images/handmesh_freihand_crops/119_img.jpg"
    "$SHARED/data/images/wilor/$(ls "$SHARED/data/images/wilor" | grep -iE '\.(jpg|png)$' | head -1)"
    "$SHARED/data/images/interwild/$(ls "$SHARED/data/images/interwild" | grep -iE '\.(jpg|png)$' | head -1)"
)
seg_s=${segment:-$((minutes * 60 / ${#photos[@]}))}
cycle_s=$((seg_s * ${#photos[@]}))
if [ $((minutes * 60 % cycle_s)) -ne 0 ]; then
    echo "--segment $seg_s: six segments must divide $minutes minutes" >&2
    exit 2
fi
repeats=$((minutes * 60 / cycle_s))
frames_in=$((minutes * 60 * 30))
video="$OUT/soak_${minutes}min_${size}.mp4"
[ -n "$segment" ] && video="$OUT/soak_${minutes}min_${size}_${seg_s}s.mp4"
if [ ! -s "$video" ]; then
    echo "== making $video ($frames_in frames)" >&2
    list="$OUT/segments.txt"
    : > "$list"
    for i in "${!photos[@]}"; do
        p=${photos[$i]}
        [ -f "$p" ] || { echo "photo not found: $p" >&2; exit 1; }
        seg="$OUT/seg_$i.mp4"
        # A camera that pans across the photo (periods of 44 and 31 s), 70% of it in view.
        ffmpeg -loglevel error -y -loop 1 -framerate 30 -i "$p" -t "$seg_s" -vf \
            "scale=${w}*2:${h}*2:force_original_aspect_ratio=increase,crop=${w}*2:${h}*2,crop=w=iw*0.7:h=ih*0.7:x='(iw-ow)/2*(1+0.9*sin(t/7))':y='(ih-oh)/2*(1+0.9*cos(t/5))',scale=${w}:${h},setsar=1,format=yuv420p" \
            -r 30 -c:v libx264 -preset ultrafast -g 60 "$seg"
    done
    for _ in $(seq "$repeats"); do
        for i in "${!photos[@]}"; do
            echo "file '$OUT/seg_$i.mp4'" >> "$list"
        done
    done
    ffmpeg -loglevel error -y -f concat -safe 0 -i "$list" -c copy "$video"
    rm -f "$OUT"/seg_*.mp4 "$list"
fi
if [ -n "$video_only" ]; then
    echo "$video"
    exit 0
fi

cargo build --release -q -p monohand-cli
bin="$CARGO_TARGET_DIR/release/monohand"
echo "== machine" >&2
lscpu | grep -E '^(Model name|CPU\(s\))' >&2 || true

mem="$OUT/memory.csv"
echo "seconds,rss_kib,frames_written" > "$mem"
rm -f "$OUT/soak.jsonl" "$OUT/soak.glb" "$OUT/soak_overlay.mp4"
start=$(date +%s)
"$bin" run "$video" --track -o "$OUT/soak.jsonl" --overlay "$OUT/soak_overlay.mp4" \
    --gltf "$OUT/soak.glb" -q &
pid=$!
while kill -0 "$pid" 2>/dev/null; do
    rss=$(awk '/^VmRSS/ {print $2}' "/proc/$pid/status" 2>/dev/null || true)
    n=0
    [ -f "$OUT/soak.jsonl" ] && n=$(wc -l < "$OUT/soak.jsonl")
    [ -n "$rss" ] && echo "$(( $(date +%s) - start )),$rss,$n" >> "$mem"
    sleep "$every"
done
status=0
wait "$pid" || status=$?
elapsed=$(( $(date +%s) - start ))

python3 "$root/bench/soak/report.py" "$OUT" "$frames_in" "$status" "$elapsed"
