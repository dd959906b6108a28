"""Shared helpers of the Python tests: the real data beside the repository, the built
command-line tool to compare with, and videos made from real photos with a moving camera.

Nothing here skips: missing data, a missing binary, ffmpeg or the networks fail the tests
(CI always has them).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import List

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[3]
SHARED = REPO.parent / "shared" / "data"


def shared(rel: str) -> Path:
    p = SHARED / rel
    assert p.exists(), f"shared data missing: {p} (../shared must sit beside the repository)"
    return p


def cli_binary() -> Path:
    p = Path(os.environ.get("MONOHAND_BIN", REPO / "target" / "release" / "monohand"))
    assert p.is_file(), f"the monohand binary is missing at {p}: cargo build --release -p monohand-cli"
    return p


def run_cli(*args: str) -> subprocess.CompletedProcess:
    out = subprocess.run([str(cli_binary()), *args], capture_output=True, text=True)
    assert out.returncode == 0, f"monohand {' '.join(args)} failed: {out.stderr}"
    return out


def records_without_timings(frames) -> List[dict]:
    """The records of `Session.track`'s frames, their timings taken out (the rest is
    deterministic)."""
    out = []
    for f in frames:
        d = f.to_dict()
        d.pop("timings_ms")
        out.append(d)
    return out


def read_jsonl(path: Path) -> List[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def rotate(q, v):
    """``v`` turned by the unit quaternion ``q = (x, y, z, w)``."""
    u, w = q[:3], q[3]
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


def dev_keypoints(step: int = 60):
    """The hand-graph-cnn dev frames' real left hand: its camera and, every ``step`` frames,
    the labels' 3D seen by it as ``(21, 3)`` keypoints (pixels and confidence 1)."""
    import monohand

    d = json.loads(shared("hand_graph_cnn_dev/labels.json").read_text())
    k = d["camera"]
    cam = monohand.Camera(k["fx"], k["fy"], k["cx"], k["cy"], k["width"], k["height"])
    labels = [np.array(f["joints_3d_mm"]) for f in d["frames"][::step]]
    return cam, [np.hstack([cam.project(j), np.ones((21, 1))]) for j in labels]


def write_lift_input(tmp_path: Path, cam, kps, side: str = "left"):
    """Keypoints and a camera as files for ``monohand lift --jsonl IN --camera CAM``."""
    src = tmp_path / "kp.jsonl"
    src.write_text(
        "".join(
            json.dumps({"frame": i, "hands": [{"side": side, "keypoints_2d": kp.tolist()}]}) + "\n"
            for i, kp in enumerate(kps)
        )
    )
    cam_path = tmp_path / "cam.json"
    cam_path.write_text(
        json.dumps({"fx": cam.fx, "fy": cam.fy, "cx": cam.cx, "cy": cam.cy, "width": cam.width, "height": cam.height})
    )
    return src, cam_path


def make_video(image: Path, out: Path, frames: int = 24, phase: float = 0.0) -> Path:
    """A real photo seen by a camera that pans, zooms and rolls: mpeg4 at 30 fps, 640x480."""
    assert shutil.which("ffmpeg"), "ffmpeg is not installed (apt-get install ffmpeg)"
    vf = (
        "scale=640:480:force_original_aspect_ratio=decrease,"
        "pad=640:480:(ow-iw)/2:(oh-ih)/2,"
        "zoompan=z='1+0.006*on':x='iw/2-iw/zoom/2+1.5*on':y='ih/2-ih/zoom/2':d=1:s=640x480:fps=30,"
        f"rotate=a='0.12*sin(2*PI*t+{phase})':c=black"
    )
    cmd = [
        "ffmpeg", "-v", "error", "-y", "-loop", "1", "-i", str(image), "-vf", vf,
        "-frames:v", str(frames), "-c:v", "mpeg4", "-q:v", "2", "-pix_fmt", "yuv420p", str(out),
    ]
    subprocess.run(cmd, check=True)
    return out


#: Real photos with hands (their licences sit beside them in ../shared).
PHOTOS = [
    "images/pinto/hand.png",
    "images/wolterlw/test_img.jpg",
    "images/hamer/test1.jpg",
    "images/hamer/test2.jpg",
    "images/hamer/test3.jpg",
    "images/wilor/test1.jpg",
    "images/wilor/test3.jpg",
    "images/interwild/image.jpg",
]


@pytest.fixture(scope="session")
def models():
    import monohand

    return monohand.Models(hands=2)


@pytest.fixture(scope="session")
def moving_video(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("video")
    return make_video(shared("images/pinto/hand.png"), d / "moving.mkv", frames=40)


@pytest.fixture(scope="session")
def corpus(tmp_path_factory) -> List[Path]:
    """Eight short videos from eight real photos, each with its own camera path."""
    d = tmp_path_factory.mktemp("corpus")
    return [
        make_video(shared(p), d / f"clip{i}.mkv", frames=16, phase=0.7 * i)
        for i, p in enumerate(PHOTOS)
    ]
