#!/usr/bin/env python3
"""The dev frames (../shared/data/hand_graph_cnn_dev) as seen by a 150 degree fisheye camera,
as issue 44 constructs them: each crop pasted into its black 1280x720 frame (as
tools/dev_video.py does), then re-rendered through OpenCV's fisheye model (equidistant,
k = 0.02, -0.005, 0, 0; 150 degrees across 1280x720, principal point at the centre), the
fisheye turned from the original camera by a yaw of 35 degrees about y, then a pitch of 10
degrees about x, so the hand sits off-centre. Each output pixel is unprojected through the
fisheye, rotated into the original camera, projected with its pinhole and sampled
(bilinear). Writes:

- OUT/fisheye.mkv: lossless FFV1, 30 fps;
- OUT/camera_info.yaml: the camera as ROS camera_info (distortion_model: equidistant);
- OUT/labels.json: the dev labels with the joints rotated into the fisheye camera, and the
  fisheye as its camera (for tools/score_dev.py --labels).

    python3 tools/fisheye_dev.py OUT_DIR [--frames A:B]

Needs numpy and ffmpeg.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DEV = REPO.parent / "shared" / "data" / "hand_graph_cnn_dev"
W, H = 1280, 720
K = (0.02, -0.005, 0.0, 0.0)
FOV_DEG = 150.0
YAW_DEG, PITCH_DEG = 35.0, 10.0


def theta_d(theta: np.ndarray) -> np.ndarray:
    t2 = theta * theta
    return theta * (1 + K[0] * t2 + K[1] * t2**2 + K[2] * t2**3 + K[3] * t2**4)


def fisheye_focal() -> float:
    """The focal length that puts 75 degrees from the axis at the image's left and right edges."""
    half = math.radians(FOV_DEG / 2)
    return (W / 2) / float(theta_d(np.array(half)))


def orientation() -> np.ndarray:
    """The fisheye's axes in the original camera: yaw about y, then pitch about the new x."""
    y, p = math.radians(YAW_DEG), math.radians(PITCH_DEG)
    ry = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
    rx = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
    return ry @ rx


def source_pixels(cam: dict, f: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each fisheye pixel, where the original pinhole sees its ray, and whether it does."""
    cx, cy = (W - 1) / 2, (H - 1) / 2
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    mx, my = (u - cx) / f, (v - cy) / f
    rd = np.hypot(mx, my)
    theta = rd.copy()
    for _ in range(20):  # Newton on theta_d(theta) = rd
        t2 = theta * theta
        g = theta_d(theta) - rd
        dg = 1 + 3 * K[0] * t2 + 5 * K[1] * t2**2 + 7 * K[2] * t2**3 + 9 * K[3] * t2**4
        theta = theta - g / dg
    s = np.where(rd > 1e-12, np.sin(theta) / np.maximum(rd, 1e-12), 1.0)
    ray = np.stack([mx * s, my * s, np.cos(theta)], axis=-1)  # in the fisheye camera
    orig = ray @ orientation().T  # into the original camera
    z = orig[..., 2]
    ok = z > 1e-6
    zs = np.where(ok, z, 1.0)
    x = cam["fx"] * orig[..., 0] / zs + cam["cx"]
    y = cam["fy"] * orig[..., 1] / zs + cam["cy"]
    ok &= (x > -1) & (x < cam["width"]) & (y > -1) & (y < cam["height"])
    return x, y, ok


def bilinear(img: np.ndarray, x: np.ndarray, y: np.ndarray, ok: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    pad = np.zeros((h + 2, w + 2, 3), dtype=np.float64)
    pad[1:-1, 1:-1] = img
    xs, ys = np.where(ok, x, -1) + 1, np.where(ok, y, -1) + 1
    x0, y0 = np.floor(xs).astype(int), np.floor(ys).astype(int)
    x0, y0 = np.clip(x0, 0, w), np.clip(y0, 0, h)
    ax, ay = (xs - x0)[..., None], (ys - y0)[..., None]
    out = (
        pad[y0, x0] * (1 - ax) * (1 - ay)
        + pad[y0, x0 + 1] * ax * (1 - ay)
        + pad[y0 + 1, x0] * (1 - ax) * ay
        + pad[y0 + 1, x0 + 1] * ax * ay
    )
    out[~ok] = 0
    return np.clip(np.round(out), 0, 255).astype(np.uint8)


def camera_info(f: float) -> str:
    cx, cy = (W - 1) / 2, (H - 1) / 2
    k = ", ".join(f"{v}" for v in K)
    return f"""image_width: {W}
image_height: {H}
camera_name: fisheye_dev
camera_matrix:
  rows: 3
  cols: 3
  data: [{f:.6f}, 0, {cx}, 0, {f:.6f}, {cy}, 0, 0, 1]
distortion_model: equidistant
distortion_coefficients:
  rows: 1
  cols: 4
  data: [{k}]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [{f:.6f}, 0, {cx}, 0, 0, {f:.6f}, {cy}, 0, 0, 0, 1, 0]
"""


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
        frames = [fr for fr in frames if a <= fr["frame"] < b]
    args.out.mkdir(parents=True, exist_ok=True)
    f = fisheye_focal()
    x, y, ok = source_pixels(cam, f)
    w, h = int(cam["width"]), int(cam["height"])
    with tempfile.TemporaryDirectory() as tmp:
        for k, fr in enumerate(frames):
            bx, by, bw, bh = (int(round(v)) for v in fr["crop_box_xywh"])
            pasted = subprocess.run(
                [
                    "ffmpeg", "-v", "error", "-f", "lavfi", "-i", f"color=black:s={w}x{h}",
                    "-i", str(DEV / fr["image"]),
                    "-filter_complex", f"[1]scale={bw}:{bh}[c];[0][c]overlay={bx}:{by}",
                    "-frames:v", "1", "-f", "rawvideo", "-pix_fmt", "rgb24", "-",
                ],
                check=True, capture_output=True,
            ).stdout
            img = np.frombuffer(pasted, dtype=np.uint8).reshape(h, w, 3).astype(np.float64)
            (Path(tmp) / f"{k:05d}.rgb").write_bytes(bilinear(img, x, y, ok).tobytes())
        raw = b"".join((Path(tmp) / f"{k:05d}.rgb").read_bytes() for k in range(len(frames)))
        subprocess.run(
            [
                "ffmpeg", "-v", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgb24",
                "-s", f"{W}x{H}", "-framerate", "30", "-i", "-",
                "-c:v", "ffv1", "-pix_fmt", "yuv420p", str(args.out / "fisheye.mkv"),
            ],
            input=raw, check=True,
        )
    (args.out / "camera_info.yaml").write_text(camera_info(f))
    to_fisheye = orientation().T  # original camera -> fisheye camera
    out_labels = dict(labels)
    out_labels["camera"] = {
        "model": "fisheye", "fx": f, "fy": f, "cx": (W - 1) / 2, "cy": (H - 1) / 2,
        "width": W, "height": H, "distortion": list(K),
    }
    out_labels["frames"] = [
        {**fr, "joints_3d_mm": (np.array(fr["joints_3d_mm"]) @ to_fisheye.T).tolist()}
        for fr in frames
    ]
    (args.out / "labels.json").write_text(json.dumps(out_labels))
    print(f"{args.out / 'fisheye.mkv'}: {len(frames)} frames, f {f:.3f} px; "
          f"{args.out / 'camera_info.yaml'}, {args.out / 'labels.json'}")


if __name__ == "__main__":
    main()
