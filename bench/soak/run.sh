#!/usr/bin/env bash
# Soak benchmark: an hour of 30 fps video through `monohand run` with tracking, the depth
# overlay video and the glTF export on, the resident memory sampled every few seconds.
# Not part of .ci/run (it takes most of an hour). Results: docs/performance.md#soak.
#
# Usage: bench/soak/run.sh [--minutes M] [--size WxH] [--every S]
#   --minutes M  length of the video (default 60)
#   --size WxH   frame size (default 320x240: the same frame count as an hour at full size
#                but cheaper to decode and encode; the networks' crops are the same size)
#   --every S    memory sampling period in seconds (default 5)
# Environment: OUT (default target/soak), CARGO_TARGET_DIR (default target), SHARED (default
#   ../shared beside the repository).
#
# The video: six segments of M/6 minutes, each a photo from $SHARED/data/images (a hand, two
# hands, a hand held up, a crop, and a photo without a hand) seen by a camera that pans
# slowly (ffmpeg's crop with time expressions), so tracking, losing and finding hands
# again, and the palm detector all run.
#
# Pass (printed at the end, exit 1 if not): frames out = frames in, every JSON Lines record
# parses, and the resident memory grows by less than 5% from the 10th minute (of video time,
# scaled for shorter runs: one sixth of the way in) to the end.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
minutes=60 size=320x240 every=5
while [ $# -gt 0 ]; do
    case "$1" in
        --minutes) minutes=$2; shift 2 ;;
        --size) size=$2; shift 2 ;;
        --every) every=$2; shift 2 ;;
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
seg_s=$((minutes * 60 / ${#photos[@]}))
frames_in=$((seg_s * 30 * ${#photos[@]}))
video="$OUT/soak_${minutes}min_${size}.mp4"
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
        echo "file '$seg'" >> "$list"
    done
    ffmpeg -loglevel error -y -f concat -safe 0 -i "$list" -c copy "$video"
    rm -f "$OUT"/seg_*.mp4 "$list"
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
    n=$(wc -l < "$OUT/soak.jsonl" 2>/dev/null || echo 0)
    [ -n "$rss" ] && echo "$(( $(date +%s) - start )),$rss,$n" >> "$mem"
    sleep "$every"
done
status=0
wait "$pid" || status=$?
elapsed=$(( $(date +%s) - start ))

python3 - "$OUT" "$frames_in" "$status" "$elapsed" <<'PY'
import csv, json, os, sys
out, frames_in, status, elapsed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
rows = list(csv.DictReader(open(os.path.join(out, "memory.csv"))))
n, bad, hands = 0, 0, 0
with open(os.path.join(out, "soak.jsonl")) as f:
    for line in f:
        try:
            rec = json.loads(line)
            hands += sum(1 for h in rec.get("hands", []) if h.get("joints_3d_mm"))
            n += 1
        except ValueError:
            bad += 1
# Memory from a sixth of the way in (the 10th minute of an hour) to the end, by frames.
warm = [r for r in rows if int(r["frames_written"]) >= frames_in // 6]
first, last = int(warm[0]["rss_kib"]), int(warm[-1]["rss_kib"])
peak = max(int(r["rss_kib"]) for r in rows)
growth = (last - first) / first
glb = os.path.getsize(os.path.join(out, "soak.glb"))
print(f"exit status {status}, {elapsed} s ({frames_in / max(elapsed, 1):.1f} fps)")
print(f"frames in {frames_in}, records out {n}, unparsable {bad}, hands in 3D {hands}")
print(f"resident memory: {first / 1024:.1f} MiB at 1/6 of the frames, {last / 1024:.1f} MiB at the end "
      f"({100 * growth:+.2f}%), peak {peak / 1024:.1f} MiB, {len(rows)} samples")
print(f"glTF {glb / 2**20:.1f} MiB, overlay video {os.path.getsize(os.path.join(out, 'soak_overlay.mp4')) / 2**20:.1f} MiB")
ok = status == 0 and n == frames_in and bad == 0 and growth < 0.05
print("PASS" if ok else "FAIL")
sys.exit(0 if ok else 1)
PY
