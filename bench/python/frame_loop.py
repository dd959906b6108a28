"""A Python frame loop against `monohand run` on the same clip, side by side (issue 43).

The loop is the one docs/python.md shows: `Session.process` over `monohand.read_video(...)`,
one frame after the other on the calling thread (the reader decodes ahead on a thread of
its own). `run` reads, runs the networks and fits on three threads. Both with the same
settings (`--hands 2 --no-heads`, the session's defaults), taking turns for `--rounds`
rounds; the networks are loaded before the timing starts on both sides (`run`'s own fps,
from its summary, counts the frames only; the loop's clock starts when the video is opened).
Prints each round and the medians, the ratio loop / run, and the machine.

    target/pyvenv/bin/python bench/python/frame_loop.py [--frames 300] [--rounds 5] [--clip FILE]
    target/pyvenv/bin/python bench/python/frame_loop.py --whole [--rounds 3]

`--whole` times whole processes instead, from start to exit, as a user meets them: `monohand
run CLIP` against `python -c` importing monohand, loading the networks and running the loop
(both pay their start and the networks' loading), frames per second of wall-clock time.

Needs the release CLI (`cargo build --release -p monohand-cli`, or `$MONOHAND_BIN`) and the
wheel installed in that venv (`scripts/test.sh` makes both). A benchmark, not a test: the
numbers are printed, never asserted.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "crates" / "monohand-py" / "tests"))

from conftest import make_video, shared  # noqa: E402
from corpus_memory import cpu_name  # noqa: E402

import monohand  # noqa: E402


def run_fps(cli: Path, clip: Path, out: Path) -> float:
    """`monohand run`'s own frames per second on `clip` (from its summary line)."""
    r = subprocess.run([str(cli), "run", str(clip), "--hands", "2", "--no-heads", "-o", str(out)],
                       check=True, capture_output=True, text=True)
    m = re.findall(r"([0-9.]+) fps", r.stderr)
    assert m, f"no fps in run's summary: {r.stderr[-500:]}"
    return float(m[-1])


def loop_fps(clip: Path, models: "monohand.Models") -> float:
    """Frames per second of `Session.process` over `read_video(clip)`."""
    with monohand.Session(None, hands=2, models=models) as s:
        start = time.perf_counter()
        n = 0
        with monohand.read_video(str(clip)) as video:
            for f in video:
                s.process(f.image, f.time_s)
                n += 1
        return n / (time.perf_counter() - start)


LOOP_SCRIPT = """
import sys, monohand
with monohand.Session(None, hands=2) as s, monohand.read_video(sys.argv[1]) as video:
    for f in video:
        s.process(f.image, f.time_s)
"""


def whole_fps(argv: list, frames: int) -> float:
    """Frames per second of one whole process, start to exit."""
    start = time.perf_counter()
    subprocess.run(argv, check=True, capture_output=True)
    return frames / (time.perf_counter() - start)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--clip", type=Path, help="a video to use instead of one made from the shared photo")
    ap.add_argument("--whole", action="store_true",
                    help="time whole processes (start, networks' loading and exit included)")
    args = ap.parse_args()
    cli = Path(os.environ.get("MONOHAND_BIN", REPO / "target" / "release" / "monohand"))
    tmp = Path(tempfile.mkdtemp(prefix="monohand-loop-"))
    clip = args.clip or make_video(shared("images/pinto/hand.png"), tmp / "clip.mkv", frames=args.frames)
    if args.whole:
        run_argv = [str(cli), "run", str(clip), "--hands", "2", "--no-heads", "-o", str(tmp / "run.jsonl")]
        loop_argv = [sys.executable, "-c", LOOP_SCRIPT, str(clip)]
        whole_fps(loop_argv, args.frames)  # warm up the page cache
        runs, loops = [], []
        for i in range(args.rounds):
            order = (run_argv, loop_argv) if i % 2 == 0 else (loop_argv, run_argv)
            for argv in order:
                (runs if argv is run_argv else loops).append(whole_fps(argv, args.frames))
            print(f"round {i + 1}: run {runs[-1]:.1f} fps, Python {loops[-1]:.1f} fps "
                  f"({loops[-1] / runs[-1]:.3f}x)", file=sys.stderr)
        r, p = statistics.median(runs), statistics.median(loops)
        print(f"whole processes, {args.frames} frames: run {r:.1f} fps, Python {p:.1f} fps, "
              f"{p / r:.3f}x (medians of {args.rounds}); {cpu_name()}, {os.cpu_count()} cores, "
              f"load {os.getloadavg()[0]:.1f}, {time.strftime('%Y-%m-%d')}")
        return
    models = monohand.Models(hands=2)
    loop_fps(clip, models)  # warm up: the page cache, the networks' first runs
    runs, loops = [], []
    for i in range(args.rounds):
        # Alternating which goes first, so that neither always follows the other.
        order = ("run", "loop") if i % 2 == 0 else ("loop", "run")
        for which in order:
            if which == "run":
                runs.append(run_fps(cli, clip, tmp / "run.jsonl"))
            else:
                loops.append(loop_fps(clip, models))
        print(f"round {i + 1}: run {runs[-1]:.1f} fps, Python loop {loops[-1]:.1f} fps "
              f"({loops[-1] / runs[-1]:.3f}x)", file=sys.stderr)
    r, p = statistics.median(runs), statistics.median(loops)
    print(f"| `monohand run --hands 2 --no-heads` | {r:.1f} | {', '.join(f'{x:.1f}' for x in runs)} |")
    print(f"| Python `Session.process` over `read_video` | {p:.1f} | {', '.join(f'{x:.1f}' for x in loops)} |")
    print(f"loop / run: {p / r:.3f}x (medians of {args.rounds} alternating rounds, {clip.name}); "
          f"{cpu_name()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}, {time.strftime('%Y-%m-%d')}")


if __name__ == "__main__":
    main()
