#!/usr/bin/env python3
"""The dev frames (../shared/data/hand_graph_cnn_dev) as the video they came from: each
256x256 crop resized to its box and pasted at its place in a black 1280x720 frame, in the
original camera. Writes a lossless FFV1 video at 30 fps and that camera as a calibration
file, for `monohand run VIDEO --camera CAMERA.json`.

    python3 tools/dev_video.py OUT_DIR [--frames A:B]

Needs only Python's standard library and ffmpeg.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DEV = REPO.parent / "shared" / "data" / "hand_graph_cnn_dev"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out", type=Path)
    ap.add_argument("--frames", default=None, help="A:B, a half-open range of frame indices")
    args = ap.parse_args()
    labels = json.loads((DEV / "labels.json").read_text())
    cam = labels["camera"]
    frames = labels["frames"]
    if args.frames:
        a, b = (int(x) for x in args.frames.split(":"))
        frames = [f for f in frames if a <= f["frame"] < b]
    args.out.mkdir(parents=True, exist_ok=True)
    w, h = int(cam["width"]), int(cam["height"])
    with tempfile.TemporaryDirectory() as tmp:
        for k, f in enumerate(frames):
            x, y, bw, bh = (int(round(v)) for v in f["crop_box_xywh"])
            subprocess.run(
                [
                    "ffmpeg", "-v", "error", "-y",
                    "-f", "lavfi", "-i", f"color=black:s={w}x{h}",
                    "-i", str(DEV / f["image"]),
                    "-filter_complex", f"[1]scale={bw}:{bh}[c];[0][c]overlay={x}:{y}",
                    "-frames:v", "1", f"{tmp}/{k:05d}.png",
                ],
                check=True,
            )
        subprocess.run(
            [
                "ffmpeg", "-v", "error", "-y", "-framerate", "30", "-i", f"{tmp}/%05d.png",
                "-c:v", "ffv1", "-pix_fmt", "yuv420p", str(args.out / "dev.mkv"),
            ],
            check=True,
        )
    camera = {k: cam[k] for k in ("fx", "fy", "cx", "cy", "width", "height")}
    (args.out / "camera.json").write_text(json.dumps(camera, indent=2) + "\n")
    print(f"{args.out / 'dev.mkv'}: {len(frames)} frames; camera {args.out / 'camera.json'}")


if __name__ == "__main__":
    main()
