"""Frames per second over a corpus of videos, side by side in one run on this machine:
`monohand run` per video, the Python `Session` (one thread, then two), `Session.track` (the
engine of `run`), and `monohand.daft`
on Daft's native runner and on a local Ray with one and two workers.

    target/pyvenv/bin/python bench/python/corpus_bench.py [--videos 8] [--frames 60]

Needs the release CLI (`cargo build --release -p monohand-cli`) and the wheel installed in
that venv (`scripts/test.sh` makes both). Prints a Markdown table for docs/python.md.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
TESTS = REPO / "crates" / "monohand-py" / "tests"
sys.path.insert(0, str(TESTS))

from conftest import PHOTOS, make_video, shared  # noqa: E402

import monohand  # noqa: E402


def cpu_name() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor()


def session_over(videos, models) -> int:
    n = 0
    for v in videos:
        with monohand.read_video(str(v)) as video, monohand.Session(None, models=models) as s:
            for f in video:
                s.process(f.image, f.time_s)
                n += 1
    return n


def track_over(videos, models) -> int:
    n = 0
    for v in videos:
        with monohand.Session(None, models=models) as s:
            for _ in s.track(str(v)):
                n += 1
    return n


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--videos", type=int, default=8)
    ap.add_argument("--frames", type=int, default=60)
    args = ap.parse_args()
    cli = Path(os.environ.get("MONOHAND_BIN", REPO / "target" / "release" / "monohand"))
    tmp = Path(tempfile.mkdtemp(prefix="monohand-bench-"))
    videos = [
        make_video(shared(PHOTOS[i % len(PHOTOS)]), tmp / f"clip{i}.mkv", frames=args.frames, phase=0.7 * i)
        for i in range(args.videos)
    ]
    total = args.videos * args.frames
    rows = []

    def record(name: str, seconds: float, note: str = "") -> None:
        rows.append((name, seconds, total / seconds, note))
        print(f"{name}: {total / seconds:.1f} fps ({seconds:.1f} s)", file=sys.stderr)

    start = time.perf_counter()
    for v in videos:
        subprocess.run([str(cli), "run", str(v), "-o", str(tmp / (v.stem + ".jsonl")), "--hands", "2", "--no-heads"],
                       check=True, capture_output=True)
    record("`monohand run`, one video after another", time.perf_counter() - start,
           "decode, networks and fit on 3 threads; loads the networks per video")

    models = monohand.Models(hands=2)
    start = time.perf_counter()
    n = session_over(videos, models)
    assert n == total
    record("Python `Session`, 1 thread", time.perf_counter() - start, "decode then process, in turn")

    start = time.perf_counter()
    n = track_over(videos, models)
    assert n == total
    record("Python `Session.track`, 1 thread", time.perf_counter() - start,
           "the engine of `run`: decode, networks and fit on 3 threads; networks loaded once")

    start = time.perf_counter()
    halves = [videos[0::2], videos[1::2]]
    threads = [threading.Thread(target=session_over, args=(h, models)) for h in halves]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    record("Python `Session`, 2 threads", time.perf_counter() - start, "one session per thread, shared networks, GIL released")

    job = TESTS / "corpus_job.py"
    for runner, workers in (("native", None), ("ray", 1), ("ray", 2)):
        cmd = [sys.executable, str(job), "--runner", runner, "--out", str(tmp / f"{runner}{workers}")]
        if workers:
            cmd += ["--workers", str(workers)]
        out = subprocess.run(cmd + [str(v) for v in videos], check=True, capture_output=True, text=True)
        seconds = json.loads(out.stdout.strip().splitlines()[-1])["seconds"]
        name = f"`monohand.daft`, {runner}" + (f", {workers} worker(s)" if workers else "")
        record(name, seconds, "plan, UDF start-up and Parquet writing included" + ("; Ray start-up excluded" if workers else ""))

    print(f"\n{args.videos} videos x {args.frames} frames, 640x480, {cpu_name()}, {os.cpu_count()} cores\n")
    print("| how | seconds | frames/s | note |\n|---|---|---|---|")
    for name, s, fps, note in rows:
        print(f"| {name} | {s:.1f} | {fps:.1f} | {note} |")


if __name__ == "__main__":
    main()
