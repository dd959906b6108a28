"""Frames per second over a corpus of videos, side by side in one run on this machine.

The corpus job (default; issue 32): `monohand.daft.track_corpus` over many short clips on
Daft's native runner (one tracker, then one per core) and on a local Ray with 2 workers,
against the sum of a single `monohand run --offline` per clip (the shell loop it replaces),
the three taking turns for each round. Reports frames/s, the corpus job's overhead over the
single runs, and the peak resident memory per process (the job's, and each Ray worker's).

    target/pyvenv/bin/python bench/python/corpus_bench.py [--videos 200] [--frames 30] [--rounds 2] [--clips DIR]

Every way (`--every-way`, the tables of 2026-11-23 and 11-25): `monohand run` per video, the
Python `Session` (one thread, then two), `Session.track` (the engine of `run`), and
`monohand.daft.track_videos` on Daft's native runner and on a local Ray with one and two
workers.

    target/pyvenv/bin/python bench/python/corpus_bench.py --every-way [--videos 8] [--frames 60]

Needs the release CLI (`cargo build --release -p monohand-cli`) and the wheel installed in
that venv (`scripts/test.sh` makes both). Prints a Markdown table for docs/python.md.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, Dict, List, Tuple

REPO = Path(__file__).resolve().parents[2]
TESTS = REPO / "crates" / "monohand-py" / "tests"
sys.path.insert(0, str(TESTS))

from conftest import PHOTOS, make_video, shared  # noqa: E402
from corpus_memory import cpu_name, status_kib, tree  # noqa: E402

import monohand  # noqa: E402


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


def every_way(args: argparse.Namespace) -> None:
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


# The corpus job, in a process of its own: track_corpus over the clips listed in a file.
CORPUS_JOB = r"""
import json, os, sys, time
import daft
runner, out, listing, workers = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
if runner == "ray":
    import ray
    ray.init(num_cpus=int(workers), include_dashboard=False, log_to_driver=False)
    daft.set_runner_ray()
else:
    daft.set_runner_native()
import monohand.daft as mhd
paths = open(listing).read().split()
start = time.perf_counter()
summary = mhd.track_corpus(paths, out, workers=int(workers) if runner == "native" else None,
                           progress=False).to_pylist()
seconds = time.perf_counter() - start
assert [r["status"] for r in summary] == ["done"] * len(paths), summary
status = dict(line.split(":", 1) for line in open("/proc/self/status"))
print(json.dumps({"seconds": seconds, "frames": sum(r["frames"] for r in summary),
                  "vmhwm_kib": int(status["VmHWM"].split()[0])}))
if runner == "ray":
    ray.shutdown()
sys.stdout.flush()
os._exit(0)  # Daft's native runner can crash the interpreter as it exits (docs/python.md)
"""


def corpus_job(runner: str, workers: int, out: Path, listing: Path) -> Dict[str, Any]:
    """Runs the corpus job; its time, frames, and the peak resident memory (VmHWM, read
    every 0.5 s) of the job's process and of each tracker's process: Daft's
    `udf_worker` on the native runner, Ray's `UDFActor` on Ray."""
    p = subprocess.Popen([sys.executable, "-c", CORPUS_JOB, runner, str(out), str(listing), str(workers)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    peaks: Dict[int, Tuple[int, str]] = {}
    while p.poll() is None:
        for pid, name in tree(p.pid)[1:]:
            rss = status_kib(pid).get("VmHWM", 0)
            tracker = "daft.execution.udf_worker" in name or name.startswith("ray::UDFActor")
            if tracker and rss > peaks.get(pid, (0, ""))[0]:
                peaks[pid] = (rss, name)
        time.sleep(0.5)
    stdout, stderr = p.communicate()
    assert p.returncode == 0, stderr[-4000:]
    result = json.loads(stdout.strip().splitlines()[-1])
    workers_mib = sorted((rss / 1024 for rss, _ in peaks.values()), reverse=True)
    result["workers_mib"] = workers_mib
    result["names"] = sorted({name.split()[0] if name.startswith("ray::") else "udf_worker" for _, name in peaks.values()})
    return result


def corpus(args: argparse.Namespace) -> None:
    cli = Path(os.environ.get("MONOHAND_BIN", REPO / "target" / "release" / "monohand"))
    tmp = Path(tempfile.mkdtemp(prefix="monohand-corpus-bench-"))
    clips = Path(args.clips) if args.clips else tmp / "clips"
    clips.mkdir(parents=True, exist_ok=True)
    # One clip per shared photo, made once per folder (`--clips`) before anything is timed,
    # and copied to make the corpus (each copy is a file, and a video, of its own).
    videos = []
    for i in range(args.videos):
        v = clips / f"clip{i:03}_{args.frames}f.mkv"
        if not v.is_file():
            if i < len(PHOTOS):
                make_video(shared(PHOTOS[i]), v, frames=args.frames, phase=0.7 * i)
            else:
                shutil.copyfile(videos[i % len(PHOTOS)], v)
        videos.append(v)
    if args.make_clips_only:
        print(clips)
        return
    listing = tmp / "videos.txt"
    listing.write_text("\n".join(str(v) for v in videos))
    total = args.videos * args.frames
    ways = ["single `run`s", "corpus, native, 1 worker", "corpus, native, 2 workers", "corpus, local Ray, 2 workers"]
    ways = [w for k, w in enumerate(ways) if k == 0 or str(k) in args.ways.split(",")]
    times: Dict[str, List[float]] = {w: [] for w in ways}
    memory: Dict[str, List[float]] = {w: [] for w in ways}
    loads: List[float] = []
    for r in range(args.rounds):
        loads.append(os.getloadavg()[0])
        # Each way in turn, the order turned round every other round.
        order = ways if r % 2 == 0 else ways[::-1]
        for way in order:
            out = tmp / f"out{r}_{ways.index(way)}"
            if way == ways[0]:
                out.mkdir()
                start = time.perf_counter()
                for v in videos:
                    subprocess.run([str(cli), "run", str(v), "-o", str(out / (v.stem + ".jsonl")), "--hands", "2",
                                    "--no-heads", "--offline", "-q"], check=True, capture_output=True)
                times[way].append(time.perf_counter() - start)
            else:
                runner = "ray" if "Ray" in way else "native"
                workers = 1 if "1 worker" in way else 2
                res = corpus_job(runner, workers, out, listing)
                assert res["frames"] == total, res
                times[way].append(res["seconds"])
                memory[way].append(max(res["workers_mib"], default=float("nan")))
                print(f"trackers: {res['names']}; peaks {[round(m) for m in res['workers_mib']]} MiB; "
                      f"the job's process {res['vmhwm_kib'] / 1024:.0f} MiB", file=sys.stderr)
            print(f"round {r + 1}, {way}: {total / times[way][-1]:.1f} frames/s", file=sys.stderr)
        loads.append(os.getloadavg()[0])

    base = sum(times[ways[0]]) / len(times[ways[0]])
    print(f"\n{args.videos} clips x {args.frames} frames, 640x480, {cpu_name()}, {os.cpu_count()} cores; "
          f"{args.rounds} rounds, each way in turn; load average {min(loads):.1f} to {max(loads):.1f}\n")
    print("| how | seconds (each round) | frames/s | against the single `run`s | peak memory per tracker process (MiB) |\n|---|---|---|---|---|")
    for way in ways:
        t = sum(times[way]) / len(times[way])
        each = ", ".join(f"{x:.1f}" for x in times[way])
        mem = f"{max(memory[way]):.0f}" if memory[way] else ""
        print(f"| {way} | {each} | {total / t:.1f} | {100 * (t / base - 1):+.1f}% | {mem} |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--every-way", action="store_true", help="the older comparison of every way (track_videos)")
    ap.add_argument("--videos", type=int, default=None, help="default: 200 (corpus) or 8 (--every-way)")
    ap.add_argument("--frames", type=int, default=None, help="default: 30 (corpus) or 60 (--every-way)")
    ap.add_argument("--rounds", type=int, default=2, help="corpus: rounds of the ways, in turn")
    ap.add_argument("--ways", default="1,2,3",
                    help="corpus: which corpus jobs beside the single runs: 1 native with 1 worker, 2 with 2, 3 Ray")
    ap.add_argument("--clips", default=None, help="corpus: the folder of the clips (made there if missing)")
    ap.add_argument("--make-clips-only", action="store_true", help="corpus: make the clips and stop")
    args = ap.parse_args()
    if args.every_way:
        args.videos, args.frames = args.videos or 8, args.frames or 60
        every_way(args)
    else:
        args.videos, args.frames = args.videos or 200, args.frames or 30
        corpus(args)


if __name__ == "__main__":
    main()
