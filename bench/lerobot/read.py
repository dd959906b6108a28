"""Reads datasets of `monohand run --lerobot DIR` with LeRobot's own `LeRobotDataset`
(PyPI `lerobot`, which imports torch: a bench, not a CI test; CI checks the layout with
pyarrow in crates/monohand-py/tests/test_lerobot.py).

    bench/lerobot/.venv/bin/python bench/lerobot/read.py DIR [DIR ...] [--every 1]

For each dataset: what LeRobot says of it (episodes, frames, fps, cameras, features), every
`--every`-th frame read through its reader (the state, the action, the decoded video frames),
and checks that LeRobot gives back what the parquet holds: the state and action, the
timestamps, and one decoded image per camera of each frame read, of the dataset's size.
Prints the timings and the machine. Exits non-zero on a mismatch.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
from lerobot.datasets.lerobot_dataset import LeRobotDataset


def cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def check(root: Path, every: int) -> bool:
    start = time.perf_counter()
    ds = LeRobotDataset(f"local/{root.name}", root=root)
    opened = time.perf_counter() - start
    table = pq.read_table(root / "data" / "chunk-000" / "file-000.parquet")
    state = np.array(table.column("observation.state").to_pylist(), dtype=np.float32)
    action = np.array(table.column("action").to_pylist(), dtype=np.float32)
    stamps = table.column("timestamp").to_numpy()
    episode = table.column("episode_index").to_numpy()
    cams = ds.meta.camera_keys
    print(f"{root}: {ds.num_episodes} episode(s), {ds.num_frames} frames at {ds.fps} fps, "
          f"cameras {cams}, opened in {opened:.2f} s")
    ok = ds.num_frames == len(state)
    start = time.perf_counter()
    n = 0
    for i in range(0, len(ds), every):
        item = ds[i]
        n += 1
        ok &= np.array_equal(item["observation.state"].numpy(), state[i])
        ok &= np.array_equal(item["action"].numpy(), action[i])
        ok &= float(item["timestamp"]) == float(stamps[i])
        ok &= int(item["episode_index"]) == int(episode[i])
        for key in cams:
            h, w, _ = ds.meta.features[key]["shape"]
            ok &= tuple(item[key].shape) == (3, h, w)
    took = time.perf_counter() - start
    print(f"  read {n} frames through LeRobotDataset in {took:.2f} s ({n / max(took, 1e-9):.1f} frames/s); "
          f"{'all match the parquet' if ok else 'MISMATCH'}")
    return ok


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("datasets", nargs="+", type=Path)
    ap.add_argument("--every", type=int, default=1)
    args = ap.parse_args()
    good = all([check(d, args.every) for d in args.datasets])
    print(f"{cpu_name()}, {os.cpu_count()} cores, {time.strftime('%Y-%m-%d')}")
    sys.exit(0 if good else 1)


if __name__ == "__main__":
    main()
