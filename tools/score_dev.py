#!/usr/bin/env python3
"""Scores `monohand run` records of the dev video (tools/dev_video.py) against the dev set's 3D
labels, as `monohand eval` does: absolute, wrist-relative, centroid-aligned and Procrustes-
aligned MPJPE, and jitter (mean joint acceleration over three consecutive scored frames, with
the labels' own on the same frames), over all frames and over each half (0-145, 146-291).

    python3 tools/score_dev.py RECORDS.jsonl [--first-frame N] [--gauss SIGMA] [--scale S]

Record k is label frame N + k (N: the first frame given to tools/dev_video.py --frames).
`--gauss SIGMA` first puts the scored joints through a Gaussian filter over time (SIGMA in
frames, truncated at 3 SIGMA, renormalised at gaps and ends): the baseline an offline
smoother has to beat.
`--scale S`: the video was scaled S times (e.g. 2 for 2560x1440, run with the camera scaled
the same way): the 2D keypoints are scaled back to 1280x720 before they are scored. The "2D"
column is the mean distance in 1280x720 pixels between the scored hand's 2D keypoints and
the 3D labels projected by the dev camera.
`--labels PATH`: labels in the dev set's schema made from it (tools/fisheye_dev.py's, whose
camera is a fisheye: the 2D column then projects through it).
Per frame the left hand with the highest mean keypoint confidence is scored. Needs numpy.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DEV = REPO.parent / "shared" / "data" / "hand_graph_cnn_dev"


def procrustes(pred: np.ndarray, gt: np.ndarray) -> np.ndarray:
    """pred aligned to gt by the best similarity transform."""
    mp, mg = pred.mean(0), gt.mean(0)
    p, g = pred - mp, gt - mg
    u, s, vt = np.linalg.svd(p.T @ g)
    d = np.sign(np.linalg.det(u @ vt))
    fix = np.diag([1.0, 1.0, d])
    r = u @ fix @ vt
    scale = (s * np.diag(fix)).sum() / (p**2).sum()
    return scale * p @ r + mg


def metrics(pred: np.ndarray, gt: np.ndarray) -> dict[str, float]:
    err = lambda a, b: float(np.linalg.norm(a - b, axis=1).mean())  # noqa: E731
    return {
        "abs": err(pred, gt),
        "wrist-rel": err(pred - pred[0], gt - gt[0]),
        "centroid": err(pred - pred.mean(0), gt - gt.mean(0)),
        "PA": err(procrustes(pred, gt), gt),
    }


def summary(rows: list[tuple[int, np.ndarray, np.ndarray]], errors_2d: dict[int, float]) -> dict[str, float]:
    out = {k: float(np.mean([metrics(p, g)[k] for _, p, g in rows])) for k in ("abs", "wrist-rel", "centroid", "PA")}
    out["2D"] = float(np.mean([errors_2d[f] for f, _, _ in rows]))
    by_frame = {f: (p, g) for f, p, g in rows}
    acc, gt_acc = [], []
    for f in sorted(by_frame):
        if f + 1 in by_frame and f + 2 in by_frame:
            (a, ga), (b, gb), (c, gc) = by_frame[f], by_frame[f + 1], by_frame[f + 2]
            acc.append(float(np.linalg.norm(a - 2 * b + c, axis=1).mean()))
            gt_acc.append(float(np.linalg.norm(ga - 2 * gb + gc, axis=1).mean()))
    out["jitter"] = float(np.mean(acc)) if acc else float("nan")
    out["labels' jitter"] = float(np.mean(gt_acc)) if gt_acc else float("nan")
    out["frames"] = len(rows)
    return out


def gaussian(rows: list[tuple[int, np.ndarray, np.ndarray]], sigma: float) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """The joints averaged over neighbouring scored frames with Gaussian weights."""
    by_frame = {f: p for f, p, _ in rows}
    reach = int(np.ceil(3 * sigma))
    out = []
    for f, _, g in rows:
        near = [(by_frame[f + k], np.exp(-0.5 * (k / sigma) ** 2)) for k in range(-reach, reach + 1) if f + k in by_frame]
        total = sum(w for _, w in near)
        out.append((f, sum(p * w for p, w in near) / total, g))
    return out


def project(cam: dict, g: np.ndarray) -> np.ndarray:
    """Pixels of camera-frame points: a pinhole, or OpenCV's fisheye (`model` fisheye)."""
    x, y = g[:, 0] / g[:, 2], g[:, 1] / g[:, 2]
    if cam.get("model") == "fisheye":
        r = np.hypot(g[:, 0], g[:, 1])
        theta = np.arctan2(r, g[:, 2])
        t2 = theta * theta
        k = cam["distortion"]
        td = theta * (1 + k[0] * t2 + k[1] * t2**2 + k[2] * t2**3 + k[3] * t2**4)
        s = np.where(r > 1e-12, td / np.maximum(r, 1e-12), 0.0)
        x, y = g[:, 0] * s, g[:, 1] * s
    return np.stack([cam["fx"] * x + cam["cx"], cam["fy"] * y + cam["cy"]], axis=1)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("records", type=Path)
    ap.add_argument("--first-frame", type=int, default=0)
    ap.add_argument("--gauss", type=float, default=0.0)
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--labels", type=Path, default=DEV / "labels.json")
    args = ap.parse_args()
    dev = json.loads(args.labels.read_text())
    cam = dev["camera"]
    labels = {f["frame"]: np.array(f["joints_3d_mm"]) for f in dev["frames"]}
    rows = []
    errors_2d = {}
    for line in args.records.read_text().splitlines():
        rec = json.loads(line)
        frame = args.first_frame + rec["frame"]
        hands = [h for h in rec.get("hands", []) if h["side"] == "left" and h.get("joints_3d_mm")]
        if frame not in labels or not hands:
            continue
        best = max(hands, key=lambda h: sum(p[2] for p in h["keypoints_2d"]))
        # Pixel centres at 1280x720 (the first pixel's centre at 0 at every scale).
        uv = (np.array(best["keypoints_2d"])[:, :2] + 0.5) / args.scale - 0.5
        g = labels[frame]
        proj = project(cam, g)
        errors_2d[frame] = float(np.linalg.norm(uv - proj, axis=1).mean())
        rows.append((frame, np.array(best["joints_3d_mm"]), labels[frame]))
    if args.gauss > 0:
        rows = gaussian(rows, args.gauss)
    parts = {
        "all": rows,
        "frames 0-145": [r for r in rows if r[0] <= 145],
        "frames 146-291": [r for r in rows if r[0] >= 146],
    }
    keys = ["frames", "2D", "abs", "wrist-rel", "centroid", "PA", "jitter", "labels' jitter"]
    print("| part | " + " | ".join(keys) + " |")
    print("|---" * (len(keys) + 1) + "|")
    for name, part in parts.items():
        if part:
            s = summary(part, errors_2d)
            print(f"| {name} | " + " | ".join(f"{s[k]:.2f}" if k != "frames" else str(s[k]) for k in keys) + " |")


if __name__ == "__main__":
    main()
