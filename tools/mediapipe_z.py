#!/usr/bin/env python3
"""MediaPipe 0.10.14's own relative depth against monohand's, on photos.

Runs MediaPipe's Python hand pipeline (`solutions.hands`, image mode, full landmark network)
and `monohand detect` on the same photos, pairs their hands by 2D keypoints (mean distance
below 10% of the hand's size), and compares the landmark `z` in image pixels: MediaPipe's
normalised `z` times the image width (its docs: "z uses roughly the same scale as x"), and
monohand's `depth_px`. Prints, per hand, the least-squares ratio monohand / MediaPipe over
the 21 joints and the mean absolute difference, then the median ratio. With `--fixture OUT`
it also writes MediaPipe's hands (u, v, z in pixels; photos relative to ../shared/data) as
JSON for crates/monohand-vision/tests/mediapipe_depth.rs.

    bench/pipeline/.venv/bin/python tools/mediapipe_z.py MONOHAND PHOTO... [--fixture OUT]

Needs the mediapipe==0.10.14 virtual environment of bench/pipeline (bench/pipeline/run.sh
makes it).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import cv2
import mediapipe as mp
import numpy as np


def mediapipe_hands(path: Path) -> list[np.ndarray]:
    """Each hand as 21 x [u, v, z] in pixels."""
    bgr = cv2.imread(str(path))
    h, w = bgr.shape[:2]
    with mp.solutions.hands.Hands(static_image_mode=True, max_num_hands=4, model_complexity=1) as hands:
        res = hands.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
    out = []
    for lms in res.multi_hand_landmarks or []:
        out.append(np.array([[l.x * w, l.y * h, l.z * w] for l in lms.landmark]))
    return out


def monohand_hands(exe: str, path: Path) -> list[np.ndarray]:
    # One landmark pass per crop, as MediaPipe reads it (the mirror pass averages two).
    cmd = [exe, "detect", str(path), "--no-heads", "--no-mirror-pass"]
    rec = subprocess.run(cmd, check=True, capture_output=True, text=True)
    line = json.loads(rec.stdout.splitlines()[0])
    out = []
    for hand in line.get("hands", []):
        if hand.get("depth_px") is None:
            continue
        k = np.array(hand["keypoints_2d"])[:, :2]
        out.append(np.column_stack([k, np.array(hand["depth_px"])]))
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("monohand")
    ap.add_argument("photos", nargs="+", type=Path)
    ap.add_argument("--fixture", type=Path)
    args = ap.parse_args()
    ratios, pairs = [], []
    for photo in args.photos:
        ours, theirs = monohand_hands(args.monohand, photo), mediapipe_hands(photo)
        for o in ours:
            size = np.ptp(o[:, :2], axis=0).max()
            best = min(theirs, key=lambda t: np.linalg.norm(t[:, :2] - o[:, :2], axis=1).mean(), default=None)
            if best is None or np.linalg.norm(best[:, :2] - o[:, :2], axis=1).mean() > 0.1 * size:
                continue
            zo, zm = o[:, 2] - o[0, 2], best[:, 2] - best[0, 2]
            ratio = float(zo @ zm / (zm @ zm))
            ratios.append(ratio)
            diff = float(np.abs(zo - zm).mean())
            print(f"{photo}: hand of {size:.0f} px, z ratio monohand/MediaPipe {ratio:.3f}, mean |dz| {diff:.2f} px")
            rel = photo.resolve().relative_to(Path(__file__).resolve().parents[2] / "shared" / "data")
            pairs.append({"photo": str(rel), "mediapipe_uvz_px": best.round(3).tolist()})
    if not ratios:
        sys.exit("no hand found by both")
    print(f"median ratio over {len(ratios)} hands: {np.median(ratios):.3f}")
    if args.fixture:
        head = json.dumps({"generator": "tools/mediapipe_z.py", "mediapipe": mp.__version__})[:-1]
        body = ",\n".join(json.dumps(h) for h in pairs)
        args.fixture.write_text(f'{head}, "hands": [\n{body}\n]}}\n')


if __name__ == "__main__":
    main()
