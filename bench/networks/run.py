#!/usr/bin/env python3
"""Per-network inference time, monohand (tract + its own operators) against LiteRT
(ai-edge-litert, XNNPACK), interleaved in one session on the same input, both on 1 thread
unless `--threads N` (LiteRT `num_threads=N`; monohand `MONOHAND_OP_THREADS=N`, its
operators sharing their rows between N threads).

Driven by bench/networks/run.sh, which builds the Rust timer (the `net_timer` example of
monohand-vision, which loads each model through `TfliteNet`) and prepares the venv.
For every round and network it times, back to back: monohand with its default importer
options, monohand with the listed importer options switched off (`--variants`, e.g. tract's
own 1x1 convolutions), then LiteRT. Medians over all runs of all rounds are reported.
"""
import argparse
import os
import shutil
import statistics
import subprocess
import tempfile
import time

import numpy as np
from ai_edge_litert.interpreter import Interpreter

NETWORKS = [
    # name, model file, input fixture (uint8 HWC), scale
    ("palm_full", "palm_detection_full.tflite", "palm_input_u8.npy"),
    ("palm_lite", "palm_detection_lite.tflite", "palm_input_u8.npy"),
    ("landmark_full", "hand_landmark_full.tflite", "landmark_input_u8.npy"),
    ("landmark_lite", "hand_landmark_lite.tflite", "landmark_input_u8.npy"),
]


def cpu_info():
    model, flags = "?", ""
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name") and model == "?":
                model = line.split(":", 1)[1].strip()
            if line.startswith("flags") and not flags:
                flags = line.split(":", 1)[1].strip()
    return model, flags


class Ours:
    def __init__(self, binary, threads):
        env = dict(os.environ, MONOHAND_OP_THREADS=str(threads))
        self.p = subprocess.Popen([binary], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                  text=True, env=env)

    def ask(self, line):
        self.p.stdin.write(line + "\n")
        self.p.stdin.flush()
        answer = self.p.stdout.readline()
        if not answer:
            raise SystemExit(f"net_timer died on: {line}")
        return answer.strip()


def litert_times(it, runs):
    out = []
    for _ in range(runs):
        t = time.perf_counter()
        it.invoke()
        out.append((time.perf_counter() - t) * 1e3)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--timer", required=True, help="the net_timer binary")
    ap.add_argument("--models", default=os.path.expanduser("~/.cache/monohand/models"))
    ap.add_argument("--fixtures", required=True, help="crates/monohand-vision/tests/fixtures")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--runs", type=int, default=20, help="timed runs per round and runtime")
    ap.add_argument("--variants", default="int8",
                    help="comma-separated extra monohand variants, each a '+'-joined list of "
                         "net_timer options (e.g. int8,no-pointwise,no-epilogue)")
    ap.add_argument("--threads", type=int, default=1,
                    help="threads for both runtimes (default 1)")
    a = ap.parse_args()

    model, flags = cpu_info()
    print(f"CPU: {model} ({os.cpu_count()} logical CPUs visible)")
    print(f"flags: {flags}")
    with open("/proc/loadavg") as f:
        print(f"load average at start: {f.read().strip()}")
    variants = ["default"] + [v.replace("+", ",") for v in a.variants.split(",") if v]

    ours = Ours(a.timer, a.threads)
    tmp = tempfile.mkdtemp(prefix="monohand-netbench-")
    lite = {}
    for name, file, fixture in NETWORKS:
        path = os.path.join(a.models, file)
        x = (np.load(os.path.join(a.fixtures, fixture)).astype(np.float32) / 255.0)[None]
        raw = os.path.join(tmp, name + ".f32")
        x.astype("<f4").tofile(raw)
        for v in variants:
            assert ours.ask(f"load {name}:{v} {path} {raw} {v}") == "ok"
        it = Interpreter(model_path=path, num_threads=a.threads)
        it.allocate_tensors()
        it.set_tensor(it.get_input_details()[0]["index"], x)
        it.invoke()
        lite[name] = it
        # Same input, same answer? (first values of output 0)
        theirs = it.get_tensor(it.get_output_details()[0]["index"]).reshape(-1)[:8]
        mine = np.array([float(v) for v in ours.ask(f"output {name}:default").split()[0].split(",")])
        print(f"{name}: first outputs differ by at most {np.abs(mine - theirs).max():.2e}")
    # net_timer read each input when it loaded the network: the files are no longer needed.
    shutil.rmtree(tmp, ignore_errors=True)

    times = {(n, v): [] for n, _, _ in NETWORKS for v in variants + ["litert"]}
    for r in range(a.rounds):
        for name, _, _ in NETWORKS:
            for v in variants:
                ms = ours.ask(f"time {name}:{v} {a.runs}").split()
                times[(name, v)] += [float(m) for m in ms]
            times[(name, "litert")] += litert_times(lite[name], a.runs)
    with open("/proc/loadavg") as f:
        print(f"load average at end: {f.read().strip()}")

    med = {k: statistics.median(v) for k, v in times.items()}
    cols = variants + ["litert"]
    head = f"{'network':<15}" + "".join(f"{('monohand ' + c if c != 'litert' else 'LiteRT 2.3'):>26}" for c in cols)
    head += "".join(f"{'ratio ' + c:>24}" for c in variants)
    threads = "1 thread" if a.threads == 1 else f"{a.threads} threads"
    print(f"\nmedian ms per inference, {threads}, {a.rounds} rounds x {a.runs} runs, interleaved")
    print(head)
    for name, _, _ in NETWORKS:
        row = f"{name:<15}" + "".join(f"{med[(name, c)]:>26.2f}" for c in cols)
        row += "".join(f"{med[(name, c)] / med[(name, 'litert')]:>24.2f}" for c in variants)
        print(row)
    print("(ratio: monohand / LiteRT; above 1 is slower than LiteRT)")


if __name__ == "__main__":
    main()
