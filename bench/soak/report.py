#!/usr/bin/env python3
"""The soak benchmark's verdict (bench/soak/run.sh calls it; it can be rerun on a finished
run's folder): frames in against records out, every JSON Lines record parsed, and the
resident memory from a sixth of the way in (the 10th minute of an hour) to the end.

Usage: report.py OUT_DIR FRAMES_IN EXIT_STATUS ELAPSED_S

The glTF writer keeps 256 bytes per hand per frame in memory until the end (21 joints x
3 floats; docs/performance.md, "Soak"). That growth is stated, not hidden: the report prints
the raw growth and the growth net of those bytes, and passes on the second (< 5%) when
the raw growth is all the glTF's.
"""
import csv
import json
import os
import sys

GLTF_BYTES_PER_HAND_FRAME = 256


def main():
    out, frames_in, status, elapsed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    rows = list(csv.DictReader(open(os.path.join(out, "memory.csv"))))
    n, bad = 0, 0
    hands_upto = []  # cumulative hands in 3D after each record
    total = 0
    with open(os.path.join(out, "soak.jsonl")) as f:
        for line in f:
            try:
                rec = json.loads(line)
            except ValueError:
                bad += 1
                continue
            total += sum(1 for h in rec.get("hands", []) if h.get("joints_3d_mm"))
            hands_upto.append(total)
            n += 1
    warm = [r for r in rows if int(r["frames_written"]) >= frames_in // 6]
    if len(warm) < 2:
        print("too few memory samples after warm-up")
        return 1
    a, b = warm[0], warm[-1]
    first, last = int(a["rss_kib"]), int(b["rss_kib"])
    peak = max(int(r["rss_kib"]) for r in rows)
    growth = (last - first) / first

    def hands_at(frames):
        return hands_upto[min(frames, len(hands_upto)) - 1] if frames > 0 and hands_upto else 0

    gltf_kib = (hands_at(int(b["frames_written"])) - hands_at(int(a["frames_written"]))) * GLTF_BYTES_PER_HAND_FRAME / 1024
    net = (last - first - gltf_kib) / first
    glb = os.path.getsize(os.path.join(out, "soak.glb")) if os.path.exists(os.path.join(out, "soak.glb")) else 0
    overlay = os.path.join(out, "soak_overlay.mp4")
    print(f"exit status {status}, {elapsed} s ({n / max(elapsed, 1):.1f} fps)")
    print(f"frames in {frames_in}, records out {n}, unparsable {bad}, hands in 3D {total}")
    print(
        f"resident memory: {first / 1024:.1f} MiB at frame {a['frames_written']}, {last / 1024:.1f} MiB at "
        f"frame {b['frames_written']} ({100 * growth:+.2f}%), peak {peak / 1024:.1f} MiB, {len(rows)} samples"
    )
    print(
        f"of which the glTF's samples: {gltf_kib / 1024:.1f} MiB ({GLTF_BYTES_PER_HAND_FRAME} B per hand "
        f"per frame); growth net of them {100 * net:+.2f}%"
    )
    size = lambda p: os.path.getsize(p) / 2**20 if os.path.exists(p) else 0.0
    print(f"glTF {glb / 2**20:.1f} MiB, overlay video {size(overlay):.1f} MiB")
    ok = status == 0 and n == frames_in and bad == 0 and net < 0.05
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
