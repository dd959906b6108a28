"""Python frame loops against `monohand run` on the same clip, side by side (issues 43, 66).

Two loops: `Session.process` over `monohand.read_video(...)`, one frame after the other on
the calling thread (the reader decodes ahead on a thread of its own), and `Session.track`
over the same reader's frames, which takes them on the engine's threads as `run` does.
`run` reads, runs the networks and fits on three threads. Both with the same
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


def frames_fps(clip: Path, models: "monohand.Models") -> float:
    """Frames per second of `Session.track` over the frames of `read_video(clip)`: the
    caller's own frames on the engine's threads."""
    with monohand.Session(None, hands=2, models=models) as s:
        start = time.perf_counter()
        n = 0
        with monohand.read_video(str(clip)) as video:
            for f in s.track(video):
                f.hands  # each frame's hands made into Python objects, as a caller would
                n += 1
        return n / (time.perf_counter() - start)


LOOP_SCRIPT = """
import sys, monohand
with monohand.Session(None, hands=2) as s, monohand.read_video(sys.argv[1]) as video:
    for f in video:
        s.process(f.image, f.time_s)
"""

FRAMES_SCRIPT = """
import sys, monohand
with monohand.Session(None, hands=2) as s, monohand.read_video(sys.argv[1]) as video:
    for f in s.track(video):
        f.hands
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
        sides = {
            "run": [str(cli), "run", str(clip), "--hands", "2", "--no-heads", "-o", str(tmp / "run.jsonl")],
            "process": [sys.executable, "-c", LOOP_SCRIPT, str(clip)],
            "track(frames)": [sys.executable, "-c", FRAMES_SCRIPT, str(clip)],
        }
        whole_fps(sides["process"], args.frames)  # warm up the page cache
        timed = {k: (lambda argv=v: whole_fps(argv, args.frames)) for k, v in sides.items()}
        what = f"whole processes, {args.frames} frames"
    else:
        models = monohand.Models(hands=2)
        loop_fps(clip, models)  # warm up: the page cache, the networks' first runs
        timed = {
            "run": lambda: run_fps(cli, clip, tmp / "run.jsonl"),
            "process": lambda: loop_fps(clip, models),
            "track(frames)": lambda: frames_fps(clip, models),
        }
        what = f"networks loaded, {clip.name}"
    got = {k: [] for k in timed}
    names = list(timed)
    for i in range(args.rounds):
        # Each round starts with another side, so that none always follows the same one.
        for k in names[i % len(names):] + names[:i % len(names)]:
            got[k].append(timed[k]())
        print(f"round {i + 1}: " + ", ".join(f"{k} {v[-1]:.1f} fps" for k, v in got.items()), file=sys.stderr)
    med = {k: statistics.median(v) for k, v in got.items()}
    label = {
        "run": "`monohand run --hands 2 --no-heads`",
        "process": "Python `Session.process` over `read_video`",
        "track(frames)": "Python `Session.track` over `read_video`'s frames",
    }
    for k, v in got.items():
        ratio = med[k] / med["run"]
        print(f"| {label[k]} | {med[k]:.1f} | {', '.join(f'{x:.1f}' for x in v)} | {ratio:.3f}x |")
    print(f"{what}; medians of {args.rounds} rounds, taking turns; {cpu_name()}, "
          f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}, {time.strftime('%Y-%m-%d')}")

if __name__ == "__main__":
    main()
