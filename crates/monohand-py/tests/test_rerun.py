"""Rerun recordings (issue 57): `monohand run --view ... --rerun hands.rrd` on two views of the
real table rig, and `Session(..., rerun=...)` from Python, read back with the rerun-sdk
wheel's own reader (`rerun.dataframe`): one entity per camera and per hand, one time point
per frame, one image and one set of keypoints per camera and frame."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path
from typing import Dict, List, Set, Tuple

import numpy as np
import pytest

import monohand
from conftest import read_jsonl, run_cli, shared

#: Frames of the rig used here (of its 148).
FRAMES = 30
#: The rig's master camera and a second one that sees the hand in these frames.
A, B = "141122079464", "141722076181"


def frames_of(serial: str, out: Path) -> Path:
    """The first FRAMES frames of one view of the rig as an H.264 video."""
    assert shutil.which("ffmpeg"), "ffmpeg is not installed (apt-get install ffmpeg)"
    src = shared(f"table_rig_dev/images/{serial}")
    cmd = [
        "ffmpeg", "-v", "error", "-y", "-framerate", "30", "-i", str(src / "color_%06d.jpg"),
        "-frames:v", str(FRAMES), "-c:v", "libx264", "-crf", "12", "-pix_fmt", "yuv420p", str(out),
    ]
    subprocess.run(cmd, check=True)
    return out


def entities(path: Path) -> Dict[str, Dict[str, int]]:
    """Each entity of the recording: its component columns and, per column, the number of
    frames (rows of the `frame` timeline) that hold a value."""
    import rerun.dataframe as rd

    rec = rd.load_recording(str(path))
    table = rec.view(index="frame", contents="/**").select().read_all()
    out: Dict[str, Dict[str, int]] = {}
    for name in table.column_names:
        if not name.startswith("/"):
            continue
        entity, _, component = name.partition(":")
        col = table.column(name)
        out.setdefault(entity, {})[component] = len(col) - col.null_count
    return out


def frames_indexed(path: Path) -> List[int]:
    import rerun.dataframe as rd

    rec = rd.load_recording(str(path))
    table = rec.view(index="frame", contents="/**").select().read_all()
    return sorted(table.column("frame").to_pylist())


def static_entities(path: Path) -> Set[str]:
    import rerun.dataframe as rd

    rec = rd.load_recording(str(path))
    return {c.entity_path for c in rec.schema().component_columns() if c.is_static}


def check_recording(path: Path, cameras: List[str], hands: Set[str], frames: int) -> None:
    got = entities(path)
    # One time point per frame.
    assert frames_indexed(path) == list(range(frames))
    for cam in cameras:
        image = got[f"/cameras/{cam}/image"]
        assert image["EncodedImage:blob"] == frames, (cam, image)
        keypoints = got[f"/cameras/{cam}/image/keypoints"]
        assert keypoints["Points2D:positions"] == frames, (cam, keypoints)
        assert f"/cameras/{cam}/image/bones" in got
    statics = static_entities(path)
    for cam in cameras:
        assert f"/cameras/{cam}" in statics and f"/cameras/{cam}/image" in statics, statics
    # One entity per hand, its joints, bones and distance in the same frames.
    found = {e.split("/")[2] for e in got if e.startswith("/hands/")}
    assert found == hands, (found, hands)
    for h in hands:
        joints = got[f"/hands/{h}/joints"]["Points3D:positions"]
        assert joints >= frames // 2, (h, joints)
        assert got[f"/hands/{h}/bones"]["LineStrips3D:strips"] == joints
        assert got[f"/hands/{h}/distance_mm"]["Scalars:scalars"] == joints


def test_the_command_line_writes_a_recording_of_the_rig(tmp_path: Path) -> None:
    for name, serial in (("A", A), ("B", B)):
        frames_of(serial, tmp_path / f"{name}.mp4")
        shutil.copy(shared(f"table_rig_dev/cameras/{serial}.json"), tmp_path / f"{name}.json")
    # Exactly the command, in the folder that holds its files.
    cmd = "run --view A.mp4 --camera A.json --view B.mp4 --camera B.json --rerun hands.rrd -o rig.jsonl"
    here = os.getcwd()
    os.chdir(tmp_path)
    try:
        run_cli(*cmd.split())
    finally:
        os.chdir(here)
    records = read_jsonl(tmp_path / "rig.jsonl")
    assert len(records) == FRAMES
    ids = {str(h["id"]) for r in records for h in r["hands"] if h.get("joints_3d_mm")}
    assert ids, "no hand fitted"
    check_recording(tmp_path / "hands.rrd", ["A", "B"], ids, FRAMES)
    # The distance over time is the records' (the joints' centre from camera A), in mm.
    import rerun.dataframe as rd

    rec = rd.load_recording(str(tmp_path / "hands.rrd"))
    h = sorted(ids)[0]
    table = rec.view(index="frame", contents=f"/hands/{h}/distance_mm").select().read_all()
    got = {
        f: v[0]
        for f, v in zip(table.column("frame").to_pylist(), table.column(f"/hands/{h}/distance_mm:Scalars:scalars").to_pylist())
        if v is not None
    }
    want = {
        r["frame"]: float(np.linalg.norm(np.mean(np.array(hand["joints_3d_mm"]), axis=0)))
        for r in records
        for hand in r["hands"]
        if str(hand.get("id")) == h and hand.get("joints_3d_mm")
    }
    assert got.keys() == want.keys()
    assert all(abs(got[f] - want[f]) < 1e-6 * want[f] for f in got)


def test_a_session_writes_the_same_recording_from_python(tmp_path: Path) -> None:
    videos = [frames_of(serial, tmp_path / f"{serial}.mp4") for serial in (A, B)]
    cameras = [monohand.Camera.load(str(shared(f"table_rig_dev/cameras/{s}.json"))) for s in (A, B)]
    path = tmp_path / "session.rrd"
    ids = set()
    with monohand.read_video(str(videos[0])) as va, monohand.read_video(str(videos[1])) as vb:
        with monohand.Session(cameras, rerun=str(path), rerun_image_scale=0.5) as s:
            for fa, fb in zip(va, vb):
                for hand in s.process([fa.image, fb.image], fa.time_s):
                    if hand.joints_3d_mm is not None:
                        ids.add(str(hand.id))
    assert ids, "no hand fitted"
    check_recording(path, ["view1", "view2"], ids, FRAMES)
    # The images were stored at half size, and the pinhole with them.
    import rerun.dataframe as rd

    rec = rd.load_recording(str(path))
    table = rec.view(index="frame", contents="/cameras/view1/image").select_static().read_all()
    resolution = table.column("/cameras/view1/image:Pinhole:resolution").to_pylist()[0]
    assert resolution == [[320.0, 240.0]], resolution
    import io

    from PIL import Image

    images = rec.view(index="frame", contents="/cameras/view2/image").select().read_all()
    blob = images.column("/cameras/view2/image:EncodedImage:blob").to_pylist()[0][0]
    assert Image.open(io.BytesIO(bytes(blob))).size == (320, 240)


def test_a_bad_image_scale_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="image scale"):
        monohand.Session(None, rerun=str(tmp_path / "x.rrd"), rerun_image_scale=0.0)


def test_a_sessions_views_look_where_the_fitted_hand_projects(tmp_path: Path) -> None:
    # Two calibrated views of the rig: with the crops from the fitted hand (the default)
    # the hand keeps one identity, and the views take part in at least as many frames as
    # when each view finds the hand itself.
    videos = [frames_of(serial, tmp_path / f"{serial}.mp4") for serial in (A, B)]
    cameras = [monohand.Camera.load(str(shared(f"table_rig_dev/cameras/{s}.json"))) for s in (A, B)]

    def views_used(fitted_crops: bool) -> List[Tuple[Set[str], int]]:
        out = []
        with monohand.read_video(str(videos[0])) as va, monohand.read_video(str(videos[1])) as vb:
            with monohand.Session(cameras, fitted_crops=fitted_crops) as s:
                for fa, fb in zip(va, vb):
                    record = s.process_dict([fa.image, fb.image], fa.time_s)
                    hands = [h for h in record["hands"] if h.get("joints_3d_mm")]
                    used = sum(sum(1 for v in h.get("views") or [] if v["used"]) for h in hands)
                    out.append(({str(h["id"]) for h in hands}, used))
        return out

    guided, alone = views_used(True), views_used(False)
    assert len(guided) == len(alone) == FRAMES
    ids = set().union(*(i for i, _ in guided))
    assert len(ids) == 1, ids
    assert sum(g for _, g in guided) >= sum(a for _, a in alone), (guided, alone)
