"""A corpus of eight real-photo videos and one damaged file, tracked with `monohand.daft` on
Daft's native runner and on a local Ray instance: every frame once, in order, equal to
`monohand run --offline` on each video (corpora are tracked offline by default), and the
damaged file an error row, not a failed job."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Dict, List

import numpy as np
import pyarrow.parquet as pq
import pytest

from conftest import read_jsonl, run_cli

HERE = Path(__file__).resolve().parent


@pytest.fixture(scope="module")
def cli_outputs(corpus, tmp_path_factory) -> Dict[str, List[dict]]:
    d = tmp_path_factory.mktemp("cli")
    out = {}
    for v in corpus:
        o = d / (v.stem + ".jsonl")
        run_cli("run", str(v), "-o", str(o), "--hands", "2", "--offline")
        out[str(v)] = read_jsonl(o)
    return out


@pytest.fixture(scope="module")
def jobs(corpus, tmp_path_factory):
    bad = tmp_path_factory.mktemp("bad") / "damaged.mp4"
    bad.write_bytes(b"\x00\x00\x00\x18ftypmp42" + bytes(range(256)) * 40)
    return [str(v) for v in corpus] + [str(bad)]


def run_job(runner: str, videos: List[str], out: Path) -> List[dict]:
    cmd = [sys.executable, str(HERE / "corpus_job.py"), "--runner", runner, "--out", str(out), *videos]
    if runner == "ray":
        cmd[4:4] = ["--workers", "2"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-4000:]
    return pq.read_table(str(out)).to_pylist()


def check(rows: List[dict], videos: List[str], cli: Dict[str, List[dict]]) -> None:
    by_video: Dict[str, List[dict]] = {}
    for r in rows:
        by_video.setdefault(r["path"], []).append(r)
    assert set(by_video) == set(videos)
    bad = videos[-1]
    assert len(by_video[bad]) == 1 and by_video[bad][0]["frame"] is None
    # The file once, then why (issue 57: it was named three times).
    error = by_video[bad][0]["error"]
    assert error.startswith(f"{bad}: ffprobe cannot read it") and error.count("damaged.mp4") == 1, error
    assert "Invalid data found when processing input" in error, error
    fitted = 0
    for v in videos[:-1]:
        got = sorted(by_video[v], key=lambda r: r["frame"])
        want = cli[v]
        assert [r["frame"] for r in got] == list(range(len(want))) == list(range(16)), v
        assert all(r["error"] is None for r in got)
        for r, w in zip(got, want):
            assert len(r["hands"]) == len(w["hands"]), (v, r["frame"])
            for h, wh in zip(r["hands"], w["hands"]):
                assert h["hand_id"] == wh["id"] and h["handedness"] == wh["side"]
                assert np.allclose(h["kp2d"], np.array(wh["keypoints_2d"])[:, :2], atol=1e-3)
                if wh.get("joints_3d_mm") is None:
                    assert h["kp3d_camera_mm"] is None
                    continue
                fitted += 1
                j = np.array(wh["joints_3d_mm"])
                assert np.allclose(h["kp3d_camera_mm"], j, atol=1e-3)
                assert np.allclose(h["kp3d"], (j - j[0]) / 1000.0, atol=1e-6)
    assert fitted >= 60, f"hands fitted over the corpus: {fitted}"


def test_corpus_on_the_native_runner(jobs, cli_outputs, tmp_path):
    check(run_job("native", jobs, tmp_path / "native"), jobs, cli_outputs)


def test_corpus_on_a_local_ray(jobs, cli_outputs, tmp_path):
    check(run_job("ray", jobs, tmp_path / "ray"), jobs, cli_outputs)


def test_images_batch_udf(corpus):
    import daft

    import monohand
    import monohand.daft as mhd

    frames = []
    with monohand.read_video(str(corpus[0])) as video:
        for f in video:
            frames.append(f.image)
            if len(frames) == 3:
                break
    df = daft.from_pydict({"image": [np.asarray(f) for f in frames]})
    df = df.with_column("image", df["image"].cast(daft.DataType.image("RGB")))
    rows = df.with_column("hands", mhd.track_images(df["image"])).to_pydict()["hands"]
    assert len(rows) == 3
    # Each image on its own, as the session without tracking sees it.
    with monohand.Session(None, tracking=False) as s:
        for img, hands in zip(frames, rows):
            want = s.process(img)
            assert len(hands) == len(want) >= 1
            assert np.allclose(hands[0]["kp3d_camera_mm"], want[0].joints_3d_mm, atol=1e-3)
