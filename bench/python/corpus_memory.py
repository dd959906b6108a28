"""Resident memory of a corpus job over long videos: `monohand.daft.track_corpus` on Daft's
native runner with one worker, one video per job. Daft runs the tracker in a worker process
of its own (`daft.execution.udf_worker`, a child of the job), which starts ffmpeg to decode:
the resident memory (VmRSS) of each of the three is sampled every few seconds from /proc,
with the worker's peak (VmHWM, the kernel's own). Issue 32's target: an hour of 640x480
video in at most 400 MB per worker.

    target/pyvenv/bin/python bench/python/corpus_memory.py [--minutes 5 60] [--segment 25] [--every 5]

The videos are bench/soak's (`bench/soak/run.sh --minutes M --size 640x480 --segment S
--video-only` makes them once, under target/soak): six clips of S seconds of shared photos
seen by a panning camera, 30 fps, repeated up to M minutes (so the 5-minute video is the
first 5 minutes of the hour). Each length runs in a fresh process, so its numbers are its own. Per
length: `OUT/memory_<M>min.csv` (seconds, the job's, the worker's and ffmpeg's resident KiB,
the worker's peak so far, bytes of Parquet written so far) and
a line of the table printed at the end (also `OUT/memory_<minutes>min.md`). OUT: `--out`,
default target/corpus_memory.

The worker's steady memory is the median of its samples after the first sixth of the video
(the 10th minute of an hour); growth is from the first such sample to the last. Needs the wheel
installed in the venv that runs this script (scripts/test.sh makes it).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Dict, List, Tuple

REPO = Path(__file__).resolve().parents[2]

# The job each length runs in a process of its own; it prints its own peak at the end.
JOB = r"""
import json, os, sys, time
import daft
daft.set_runner_native()
import monohand.daft as mhd
start = time.perf_counter()
summary = mhd.track_corpus([sys.argv[1]], sys.argv[2], workers=1, progress=False).to_pylist()
seconds = time.perf_counter() - start
status = dict(line.split(":", 1) for line in open("/proc/self/status"))
print(json.dumps({"seconds": seconds, "frames": summary[0]["frames"], "status": summary[0]["status"],
                  "reason": summary[0]["reason"], "hands": summary[0]["hands"],
                  "vmhwm_kib": int(status["VmHWM"].split()[0]), "vmrss_kib": int(status["VmRSS"].split()[0])}))
sys.stdout.flush()
os._exit(0)  # Daft's native runner can crash the interpreter as it exits (docs/python.md)
"""


def cpu_name() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor()


def soak_video(minutes: int, segment: int) -> Path:
    out = subprocess.run(
        ["bash", str(REPO / "bench" / "soak" / "run.sh"), "--minutes", str(minutes), "--size", "640x480",
         "--segment", str(segment), "--video-only"],
        check=True, capture_output=True, text=True, env={k: v for k, v in os.environ.items() if k != "OUT"},
    )
    return Path(out.stdout.strip().splitlines()[-1])


def status_kib(pid: int) -> Dict[str, int]:
    """VmRSS and VmHWM of a process, KiB (empty once it has ended)."""
    out = {}
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith(("VmRSS:", "VmHWM:")):
                out[line.split(":")[0]] = int(line.split()[1])
    except OSError:
        pass
    return out


def tree(root: int) -> List[Tuple[int, str]]:
    """The processes under `root` (itself included), with their command lines."""
    children: Dict[int, List[int]] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(d.name))
    out, todo = [], [root]
    while todo:
        pid = todo.pop()
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        out.append((pid, cmd))
        todo += children.get(pid, [])
    return out


def written(out: Path) -> int:
    return sum(f.stat().st_size for f in out.glob("*parquet*") if f.is_file()) if out.is_dir() else 0


def measure(minutes: int, segment: int, every: float, work: Path) -> dict:
    video = soak_video(minutes, segment)
    out = work / f"out_{minutes}min"
    if out.exists():
        for f in out.iterdir():
            f.unlink()
    csv_path = work / f"memory_{minutes}min.csv"
    p = subprocess.Popen([sys.executable, "-c", JOB, str(video), str(out)], stdout=subprocess.PIPE, text=True)
    start = time.monotonic()
    samples = []
    worker_hwm = 0
    with open(csv_path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["seconds", "job_rss_kib", "worker_rss_kib", "worker_hwm_kib", "ffmpeg_rss_kib", "parquet_bytes"])
        while p.poll() is None:
            job = status_kib(p.pid).get("VmRSS", 0)
            worker = ffmpeg = 0
            for pid, cmd in tree(p.pid)[1:]:
                st = status_kib(pid)
                if "daft.execution.udf_worker" in cmd:
                    worker = st.get("VmRSS", 0)
                    worker_hwm = max(worker_hwm, st.get("VmHWM", 0))
                elif cmd.startswith("ffmpeg"):
                    ffmpeg = st.get("VmRSS", 0)
            row = (round(time.monotonic() - start, 1), job, worker, worker_hwm, ffmpeg, written(out))
            samples.append(row)
            w.writerow(row)
            f.flush()
            time.sleep(every)
    result = json.loads(p.stdout.read().strip().splitlines()[-1])
    assert p.returncode == 0 and result["status"] == "done", result
    # Steady state: after the first sixth of the video (by time: the frame rate is even).
    warm = [s[2] for s in samples if s[0] >= result["seconds"] / 6 and s[2] > 0]
    return {
        "minutes": minutes,
        "frames": result["frames"],
        "hands": result["hands"],
        "seconds": result["seconds"],
        "fps": result["frames"] / result["seconds"],
        "job_peak_mib": result["vmhwm_kib"] / 1024,
        "worker_peak_mib": worker_hwm / 1024,
        "worker_steady_mib": statistics.median(warm) / 1024 if warm else float("nan"),
        "worker_first_mib": warm[0] / 1024 if warm else float("nan"),
        "worker_last_mib": warm[-1] / 1024 if warm else float("nan"),
        "ffmpeg_peak_mib": max(s[4] for s in samples) / 1024,
        "samples": len(samples),
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=int, nargs="+", default=[5, 60])
    ap.add_argument("--segment", type=int, default=25, help="seconds of each photo's clip")
    ap.add_argument("--every", type=float, default=5.0)
    ap.add_argument("--out", default=str(REPO / "target" / "corpus_memory"))
    args = ap.parse_args()
    work = Path(args.out)
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    for m in args.minutes:
        load = os.getloadavg()[0]
        r = measure(m, args.segment, args.every, work)
        r["load"] = load
        rows.append(r)
        print(json.dumps(r), file=sys.stderr)
    lines = [
        f"{cpu_name()}, {os.cpu_count()} cores; load average at the start of each run in the table",
        "",
        "| video | frames | hands | frames/s | worker: peak | worker: steady | worker: a sixth in → end "
        "| its ffmpeg | driver: peak | load |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        growth = r["worker_last_mib"] - r["worker_first_mib"]
        lines.append(
            f"| {r['minutes']} min 640x480 | {r['frames']} | {r['hands']} | {r['fps']:.1f} "
            f"| {r['worker_peak_mib']:.0f} MiB | {r['worker_steady_mib']:.0f} MiB "
            f"| {r['worker_first_mib']:.0f} → {r['worker_last_mib']:.0f} MiB ({growth:+.1f}) "
            f"| {r['ffmpeg_peak_mib']:.0f} MiB | {r['job_peak_mib']:.0f} MiB | {r['load']:.1f} |"
        )
    text = "\n".join(lines)
    print(text)
    (work / f"memory_{'_'.join(map(str, args.minutes))}min.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
