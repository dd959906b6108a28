"""monohand.calibrate against `monohand calibrate` on OpenCV's real chessboard photos."""

import json
import os
import subprocess
from pathlib import Path

import pytest

import monohand
from conftest import shared

PHOTOS = shared("calibration/opencv_stereo_chessboard")


def test_python_and_the_command_line_give_the_same_camera(tmp_path: Path) -> None:
    left = sorted(PHOTOS.glob("left*.jpg"))
    assert len(left) == 13
    out = tmp_path / "py.json"
    result = monohand.calibrate([str(p) for p in left], board="9x6", square_mm=25, output=out)
    assert result["written"] == [str(out)]
    cam = result["cameras"][0]
    # OpenCV's calibrateCamera on its own corners (winSize 5): fx 532.827, RMS 0.1954.
    assert abs(cam["fx"] / 532.827 - 1) < 0.005 and abs(cam["rms_px"] - 0.1954) < 0.05
    assert cam["views"] == 13 and "a hand at 0.5 m" in result["summary"]
    cli = tmp_path / "cli.json"
    binary = os.environ.get("MONOHAND_BIN", "monohand")
    subprocess.run(
        [binary, "calibrate", "--board", "9x6", "--square-mm", "25", f"{PHOTOS}/left*.jpg", "-o", str(cli)],
        check=True,
    )
    a, b = json.loads(out.read_text()), json.loads(cli.read_text())
    a.pop("date"), b.pop("date")
    assert a == b
    # The camera loads as a monohand.Camera.
    loaded = monohand.Camera.load(out)
    assert loaded.fx == cam["fx"]


def test_a_rig_and_bad_input(tmp_path: Path) -> None:
    rig = monohand.calibrate(
        views=[f"{PHOTOS}/left*.jpg", f"{PHOTOS}/right*.jpg"], board="9x6", square_mm=25
    )
    assert len(rig["cameras"]) == 2 and rig["written"] == []
    t = rig["cameras"][1]["t"]
    assert abs((t[0] ** 2 + t[1] ** 2 + t[2] ** 2) ** 0.5 - 83.18) < 0.8
    with pytest.raises(ValueError, match="COLSxROWS"):
        monohand.calibrate(str(PHOTOS), board="nine by six", square_mm=25)
    with pytest.raises(monohand.MonohandError, match="a chessboard with 9x6 inner corners"):
        monohand.calibrate(f"{PHOTOS}/left*.jpg", board="8x6", square_mm=25, output=tmp_path / "x.json")
    assert not (tmp_path / "x.json").exists()


def test_the_fisheye_model(tmp_path: Path) -> None:
    # OpenCV's fisheye model on a 60 degree lens: the same focal length as the pinhole's
    # (532.3 here; OpenCV's pinhole 532.827) and an RMS near its 0.195 px (0.203 measured
    # by crates/monohand-calib/tests/end_to_end.rs on the same corners).
    out = tmp_path / "fisheye.json"
    result = monohand.calibrate(f"{PHOTOS}/left*.jpg", board="9x6", square_mm=25, output=out, model="fisheye")
    cam = result["cameras"][0]
    assert cam["model"] == "fisheye" and len(cam["dist"]) == 4
    assert abs(cam["fx"] / 532.827 - 1) < 0.005 and cam["rms_px"] < 0.25
    assert "fisheye" in result["summary"]
    assert monohand.Camera.load(out).fx == cam["fx"]
    with pytest.raises(ValueError, match="not standard, rational or fisheye"):
        monohand.calibrate(str(PHOTOS), board="9x6", square_mm=25, model="omni")
