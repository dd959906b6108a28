"""`monohand run --lerobot DIR` (issue 65): a LeRobot v3 dataset, read back here with pyarrow
and pandas as LeRobot's reader reads it (bench/robots/lerobot_read.py loads it with LeRobot's
own `LeRobotDataset`): the v3 layout, the state against the run's own records, the action
as the next state, the videos' frames, a failed run's dataset, a folder that is not new."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

import monohand

from conftest import cli_binary, read_jsonl, run_cli, shared

NAMES = list(monohand.JOINT_NAMES)
HAND = 1 + 63 + 7


def video_frames(path: Path) -> tuple:
    out = subprocess.run(
        ["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
         "stream=nb_read_frames,width,height,codec_name", "-of", "json", str(path)],
        check=True, capture_output=True, text=True,
    )
    s = json.loads(out.stdout)["streams"][0]
    return int(s["nb_read_frames"]), s["width"], s["height"], s["codec_name"]


def read_dataset(ds: Path, views: int = 1) -> dict:
    """Every table of a one-episode dataset, checked against the v3 layout and each other."""
    info = json.loads((ds / "meta" / "info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["total_episodes"] == 1
    assert info["data_path"] == "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    assert info["video_path"] == "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
    n, fps = info["total_frames"], info["fps"]
    assert isinstance(fps, int) and info["splits"] == {"train": "0:1"}
    feats = info["features"]
    for key in ("observation.state", "action"):
        assert feats[key]["dtype"] == "float32" and feats[key]["shape"] == [2 * HAND]
        assert len(feats[key]["names"]) == 2 * HAND == len(set(feats[key]["names"]))
    names = feats["observation.state"]["names"]
    assert names[0] == "left.valid" and names[HAND] == "right.valid"
    assert names[1:4] == ["left.wrist.x_m", "left.wrist.y_m", "left.wrist.z_m"]
    assert [names[1 + 3 * j][len("left."):-len(".x_m")] for j in range(21)] == NAMES
    assert names[HAND - 7:HAND] == [f"left.wrist_pose.{v}" for v in ("x_m", "y_m", "z_m", "qx", "qy", "qz", "qw")]
    data = pq.read_table(ds / "data" / "chunk-000" / "file-000.parquet")
    assert data.num_rows == n
    assert set(data.column_names) == {"observation.state", "action", "timestamp", "frame_index",
                                      "episode_index", "index", "task_index"}
    assert set(feats) == set(data.column_names) | {f"observation.images.view{v + 1}" for v in range(views)}
    t = data.column("timestamp").to_numpy()
    assert t.dtype == np.float32 and np.array_equal(t, (np.arange(n) / fps).astype(np.float32))
    assert data.column("frame_index").to_pylist() == list(range(n)) == data.column("index").to_pylist()
    assert set(data.column("episode_index").to_pylist()) == {0} == set(data.column("task_index").to_pylist())
    state = np.array(data.column("observation.state").to_pylist(), dtype=np.float32)
    action = np.array(data.column("action").to_pylist(), dtype=np.float32)
    assert state.shape == action.shape == (n, 2 * HAND)
    assert np.array_equal(action[:-1], state[1:]) and np.array_equal(action[-1], state[-1])
    episodes = pq.read_table(ds / "meta" / "episodes" / "chunk-000" / "file-000.parquet").to_pylist()
    assert len(episodes) == 1
    e = episodes[0]
    assert (e["episode_index"], e["length"], e["dataset_from_index"], e["dataset_to_index"]) == (0, n, 0, n)
    tasks = pd.read_parquet(ds / "meta" / "tasks.parquet")
    assert list(tasks.index) == e["tasks"] and tasks.loc[e["tasks"][0]].task_index == 0
    stats = json.loads((ds / "meta" / "stats.json").read_text())
    assert stats["observation.state"]["count"] == [n] and len(stats["observation.state"]["mean"]) == 2 * HAND
    assert np.allclose(stats["observation.state"]["mean"], state.mean(axis=0), atol=1e-6)
    for v in range(views):
        key = f"observation.images.view{v + 1}"
        h, w, c = feats[key]["shape"]
        assert feats[key]["dtype"] == "video" and c == 3 and feats[key]["info"]["video.fps"] == fps
        frames, vw, vh, codec = video_frames(ds / "videos" / key / "chunk-000" / "file-000.mp4")
        assert (frames, vw, vh) == (n, w, h), (key, frames, n)
        assert codec == feats[key]["info"]["video.codec"]
        assert e[f"videos/{key}/from_timestamp"] == 0.0 and abs(e[f"videos/{key}/to_timestamp"] - n / fps) < 1e-9
        img = np.array(stats[key]["mean"])
        assert img.shape == (3, 1, 1) and ((0 < img) & (img < 1)).all()
    assert not any(p.name.endswith("monohand-partial") for p in ds.parent.iterdir())
    return {"info": info, "state": state, "episode": e}


def test_run_writes_a_lerobot_v3_dataset_of_its_records(tmp_path, moving_video):
    ds = tmp_path / "hands"
    out = tmp_path / "run.jsonl"
    run_cli("run", str(moving_video), "--hands", "2", "-o", str(out), "--wrist-pose",
            "--lerobot", str(ds), "--lerobot-task", "wave at the camera")
    records = read_jsonl(out)
    got = read_dataset(ds)
    info, state = got["info"], got["state"]
    assert info["total_frames"] == len(records) == 40 and info["fps"] == 30
    assert got["episode"]["tasks"] == ["wave at the camera"]
    episode = info["monohand"]["episodes"][0]
    assert episode["cameras"] == records[-1]["cameras"] and episode["source"] == moving_video.name
    assert episode["hand_size"]["source"] == "default" and episode["task"] == "wave at the camera"
    valid = 0
    for row, rec in zip(state, records):
        for slot, side in enumerate(("left", "right")):
            hand = next((h for h in rec["hands"] if h["side"] == side and h.get("joints_3d_mm")), None)
            part = row[slot * HAND:(slot + 1) * HAND]
            if hand is None:
                assert not part.any(), (rec["frame"], side)
                continue
            valid += 1
            assert part[0] == 1.0
            joints = (np.array(hand["joints_3d_mm"]) / 1000.0).astype(np.float32)
            assert np.array_equal(part[1:64].reshape(21, 3), joints)
            m = np.array(hand["wrist_pose"]["matrix_m"])
            assert np.allclose(part[64:67], m[:3, 3], atol=1e-6)
            x, y, z, w = part[67:71].astype(np.float64)
            rot = np.array([
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
            ])
            assert np.allclose(rot, m[:3, :3], atol=1e-5), rec["frame"]
    assert valid >= 38, f"the photo's hand is in the state of nearly every frame ({valid}/40)"


def test_a_rig_gives_a_video_per_view(tmp_path):
    rig = shared("table_rig_dev")
    ds = tmp_path / "rig"
    args = ["run"]
    for s in ("141122079464", "141722072294"):
        args += ["--view", str(rig / "images" / s), "--camera", str(rig / "cameras" / f"{s}.json")]
    run_cli(*args, "--max-frames", "12", "-o", str(tmp_path / "rig.jsonl"), "--lerobot", str(ds))
    got = read_dataset(ds, views=2)
    assert got["info"]["total_frames"] == 12 and len(got["info"]["monohand"]["episodes"][0]["cameras"]) == 2
    assert got["state"][:, [0, HAND]].max() == 1.0, "a hand fitted in some frame"
    # A view that started 5 frames late: black frames until its first, a frame per row.
    late = tmp_path / "late"
    said = run_cli(*args, "--sync", str(5 / 30), "--max-frames", "12", "-o", str(tmp_path / "late.jsonl"),
                   "--lerobot", str(late)).stderr
    assert "view 2 has not started yet" in said, said
    got = read_dataset(late, views=2)
    assert got["info"]["total_frames"] == 12


def test_a_failed_run_leaves_the_frames_before_and_a_used_folder_is_refused(tmp_path, moving_video):
    ds = tmp_path / "hands"
    env = dict(os.environ, MONOHAND_FAULT="network-panic:12")
    failed = subprocess.run(
        [str(cli_binary()), "run", str(moving_video), "-o", str(tmp_path / "a.jsonl"), "--lerobot", str(ds)],
        capture_output=True, text=True, env=env,
    )
    assert failed.returncode != 0 and "network" in failed.stderr, failed.stderr
    got = read_dataset(ds)
    assert got["info"]["total_frames"] == 12, "the frames fitted before the failure, whole"
    # A folder that holds anything is refused, and left as it was.
    again = subprocess.run(
        [str(cli_binary()), "run", str(moving_video), "-o", str(tmp_path / "b.jsonl"), "--lerobot", str(ds)],
        capture_output=True, text=True,
    )
    assert again.returncode != 0 and "already holds files" in again.stderr, again.stderr
    assert read_dataset(ds)["info"]["total_frames"] == 12
    # What a killed run leaves (its folder beside the dataset) is not a dataset, and is
    # replaced by the next run.
    stale = tmp_path / ".fresh.monohand-partial"
    (stale / "data").mkdir(parents=True)
    (stale / "data" / "junk").write_text("half a file")
    run_cli("run", str(moving_video), "--max-frames", "5", "-o", str(tmp_path / "c.jsonl"),
            "--lerobot", str(tmp_path / "fresh"))
    assert read_dataset(tmp_path / "fresh")["info"]["total_frames"] == 5
    assert not stale.exists()


def test_each_makes_one_dataset_of_every_inputs_episode(tmp_path, moving_video):
    """`run --each DIR --output-dir OUT --lerobot DS`: each input's episode kept beside its
    records, one dataset of them all (an input of another frame size left out, and said);
    a rerun skips what is done and makes the same dataset again."""
    src = tmp_path / "in"
    src.mkdir()
    (src / "a.mkv").write_bytes(moving_video.read_bytes())
    subprocess.run(["ffmpeg", "-v", "error", "-i", str(moving_video), "-frames:v", "15",
                    "-c:v", "mpeg4", str(src / "b.mp4")], check=True)
    (src / "c.jpg").write_bytes(shared("images/hamer/test1.jpg").read_bytes())
    out, ds = tmp_path / "out", tmp_path / "ds"
    args = ["run", "--each", str(src), "--output-dir", str(out), "--lerobot", str(ds),
            "--lerobot-task", "wave"]
    first = run_cli(*args)
    assert "c.jpg.lerobot left out" in first.stderr and "2 episodes, 55 frames" in first.stderr, first.stderr
    assert sorted(p.name for p in out.iterdir()) == [
        "a.mkv.jsonl", "a.mkv.lerobot", "b.mp4.jsonl", "b.mp4.lerobot", "c.jpg.jsonl", "c.jpg.lerobot"]
    info = json.loads((ds / "meta" / "info.json").read_text())
    assert (info["total_episodes"], info["total_frames"], info["total_tasks"]) == (2, 55, 1)
    assert [e["source"] for e in info["monohand"]["episodes"]] == ["a.mkv", "b.mp4"]
    data = pq.read_table(ds / "data" / "chunk-000" / "file-000.parquet")
    assert data.column("index").to_pylist() == list(range(55))
    assert data.column("episode_index").to_pylist() == [0] * 40 + [1] * 15
    assert data.column("frame_index").to_pylist() == list(range(40)) + list(range(15))
    state = np.array(data.column("observation.state").to_pylist(), dtype=np.float32)
    action = np.array(data.column("action").to_pylist(), dtype=np.float32)
    assert np.array_equal(action[39], state[39]) and np.array_equal(action[40:54], state[41:55])
    # Each episode's rows are its own run's, and its video a file of its own.
    for k, (name, n) in enumerate([("a.mkv", 40), ("b.mp4", 15)]):
        part = pq.read_table(out / f"{name}.lerobot" / "data" / "chunk-000" / "file-000.parquet")
        rows = data.column("episode_index").to_numpy() == k
        assert np.array_equal(np.array(part.column("observation.state").to_pylist(), dtype=np.float32), state[rows])
        video = ds / "videos" / "observation.images.view1" / "chunk-000" / f"file-{k:03d}.mp4"
        assert video_frames(video)[:3] == (n, 640, 480)
    episodes = pq.read_table(ds / "meta" / "episodes" / "chunk-000" / "file-000.parquet").to_pylist()
    assert [(e["dataset_from_index"], e["dataset_to_index"]) for e in episodes] == [(0, 40), (40, 55)]
    assert [e["videos/observation.images.view1/file_index"] for e in episodes] == [0, 1]
    assert list(pd.read_parquet(ds / "meta" / "tasks.parquet").index) == ["wave"]
    again = run_cli(*args)
    assert again.stderr.count("already done, skipped") == 3, again.stderr
    assert json.loads((ds / "meta" / "info.json").read_text()) == info
    assert pq.read_table(ds / "data" / "chunk-000" / "file-000.parquet").equals(data)


CORPUS_JOB = """
import sys, daft
daft.set_runner_native()
import monohand.daft as mhd
mhd.track_corpus(sys.argv[3:], sys.argv[1], workers=1, lerobot=sys.argv[2], lerobot_task="grasp")
"""


def test_python_writes_the_same_datasets(tmp_path, moving_video, models, corpus):
    """`Session.track(lerobot=DIR)` writes `run --lerobot`'s dataset (the same state bit for
    bit, the same one path), and `monohand.daft.track_corpus(lerobot=DS)` one dataset of
    every finished video, made again by a rerun."""
    cli = tmp_path / "cli"
    run_cli("run", str(moving_video), "--hands", "2", "-o", str(tmp_path / "r.jsonl"), "--lerobot", str(cli))
    py = tmp_path / "py"
    with monohand.Session(None, hands=2, models=models) as s:
        frames = list(s.track(str(moving_video), lerobot=py))
        assert len(frames) == 40
    a, b = read_dataset(cli), read_dataset(py)
    assert np.array_equal(a["state"], b["state"])
    assert b["info"]["monohand"]["episodes"][0]["source"] == moving_video.name
    with monohand.Session(None, hands=2, models=models) as s:
        with pytest.raises(monohand.MonohandError, match="already holds files"):
            s.track(str(moving_video), lerobot=py)

    out, ds = tmp_path / "corpus", tmp_path / "ds"
    videos = [str(v) for v in corpus[:3]]
    job = [sys.executable, "-c", CORPUS_JOB, str(out), str(ds), *videos]
    first = subprocess.run(job, capture_output=True, text=True)
    assert first.returncode == 0, first.stderr
    assert "lerobot " + str(ds) + ": 3 episodes, 48 frames" in first.stderr, first.stderr
    info = json.loads((ds / "meta" / "info.json").read_text())
    assert [e["source"] for e in info["monohand"]["episodes"]] == [Path(v).name for v in videos]
    assert [e["task"] for e in info["monohand"]["episodes"]] == ["grasp"] * 3
    data = pq.read_table(ds / "data" / "chunk-000" / "file-000.parquet")
    assert data.column("episode_index").to_pylist() == [0] * 16 + [1] * 16 + [2] * 16
    for k in range(3):
        video = ds / "videos" / "observation.images.view1" / "chunk-000" / f"file-{k:03d}.mp4"
        assert video_frames(video)[:3] == (16, 640, 480)
    again = subprocess.run(job, capture_output=True, text=True)
    assert again.returncode == 0 and "3 already done" in again.stderr, again.stderr
    assert json.loads((ds / "meta" / "info.json").read_text()) == info
    assert pq.read_table(ds / "data" / "chunk-000" / "file-000.parquet").equals(data)
