"""A calibrated rig's videos in `Session.track` (a list of paths, one per camera) and
`sync`: on the real table rig (`../shared/data/table_rig_dev`, 4 views, 60 frames), a
view that started 5 frames late is found by `sync="auto"`, every frame's cameras say each
view's `time_offset_s`, and the 3D is the 3D of the views as recorded; the offsets given
as a list give the same frames."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path
from typing import List

import numpy as np
import pytest

import monohand
from conftest import records_without_timings, shared

SERIALS = ["141122079464", "141722072294", "141722075121", "141722076181"]
FRAMES = 60


def rig() -> Path:
    return shared("table_rig_dev")


def session() -> monohand.Session:
    cams = [monohand.Camera.load(rig() / "cameras" / f"{s}.json") for s in SERIALS]
    return monohand.Session(cameras=cams)


def joints(frames) -> List[np.ndarray]:
    out = []
    for f in frames:
        fitted = [h for h in f.hands if h.joints_3d_mm is not None]
        out.append(np.asarray(fitted[0].joints_3d_mm) if fitted else None)
    return out


def test_a_rig_tracks_its_views_and_sync_auto_finds_a_late_one(tmp_path):
    views = [rig() / "images" / s for s in SERIALS]
    # View 2 started 5 frames late (it sees the hand from frame 25 on: the frames before
    # fit the same without it; a view that took part would change the tracks for a while).
    late = tmp_path / "late"
    late.mkdir()
    for i in range(5, 148):
        (late / f"color_{i - 5:06d}.jpg").symlink_to(views[1] / f"color_{i:06d}.jpg")
    with session() as s:
        recorded = list(s.track([str(v) for v in views], max_frames=FRAMES))
        shifted = views[:1] + [late] + views[2:]
        found = list(s.track(shifted, max_frames=FRAMES, sync="auto"))
        given = list(s.track(shifted, max_frames=FRAMES, sync=[5 / 30, 0.0, 0.0]))
        by_index = list(s.track(shifted, max_frames=FRAMES))
    assert len(recorded) == len(found) == len(given) == FRAMES
    offsets = [c["time_offset_s"] for c in found[10].cameras]
    assert offsets == pytest.approx([0.0, 5 / 30, 0.0, 0.0], abs=1e-6), offsets
    assert "time_offset_s" not in recorded[10].cameras[0]
    a, b, c, d = joints(recorded), joints(found), joints(given), joints(by_index)
    # View 2 has its frames of the same moment: the recorded run's 3D.
    worst = max(np.abs(x - y).max() for x, y in zip(a[5:], b[5:]) if x is not None and y is not None)
    assert worst < 0.5, worst
    assert all(np.array_equal(x, y) for x, y in zip(b, c) if x is not None and y is not None)
    off = max(np.abs(x - y).max() for x, y in zip(a[5:], d[5:]) if x is not None and y is not None)
    assert off > 5.0, off


def test_sync_is_refused_without_a_rig_or_with_the_wrong_offsets():
    views = [str(rig() / "images" / s) for s in SERIALS]
    with session() as s:
        with pytest.raises(ValueError, match="one finite number of seconds each"):
            s.track(views, sync=[0.1])
        with pytest.raises(ValueError, match="a list of seconds"):
            s.track(views, sync=3)
    with monohand.Session() as s:
        with pytest.raises(ValueError, match="two or more"):
            s.track(views[0], sync="auto")


def test_a_rigs_frames_from_the_caller_are_its_videos(tmp_path):
    """A rig's frames given by the caller (each item a list of one image per camera, from
    `read_video` of each view) give the records of `track` over the same videos."""
    assert shutil.which("ffmpeg"), "ffmpeg is not installed (apt-get install ffmpeg)"
    videos = []
    for s in SERIALS:
        out = tmp_path / f"{s}.mkv"
        subprocess.run(
            ["ffmpeg", "-v", "error", "-y", "-framerate", "30", "-i",
             str(rig() / "images" / s / "color_%06d.jpg"), "-frames:v", "24",
             "-c:v", "ffv1", str(out)],
            check=True,
        )
        videos.append(str(out))

    readers = [monohand.read_video(v) for v in videos]
    with session() as s:
        by_paths = records_without_timings(s.track(videos))
        by_frames = records_without_timings(s.track([f.image for f in views] for views in zip(*readers)))
    for r in readers:
        r.close()
    assert len(by_paths) == 24
    fitted = sum(1 for d in by_paths for h in d["hands"] if h.get("joints_3d_mm"))
    assert fitted >= 12, fitted
    # Bare images carry no time: 1/30 s apart, as the videos' own clock here.
    for d in by_paths:
        d["time_s"] = None
    for d in by_frames:
        d["time_s"] = None
    assert by_frames == by_paths
