#!/usr/bin/env python3
"""MediaPipe's Python hand pipeline against `monohand run` on the same video.

Run through bench/pipeline/run.sh (which makes the virtual environment, builds monohand and
the video). Two subcommands:

  bench.py mediapipe VIDEO --max-hands N --out LANDMARKS.json
      one timed MediaPipe run (the legacy `solutions.hands`, video mode); prints one JSON
      line {frames, seconds, fps, cpu_s}.
  bench.py compare VIDEO --monohand BIN --rounds R --out DIR
      alternates MediaPipe and monohand runs, R rounds, and prints the tables (also written
      to DIR/report.md).
  bench.py sizes VIDEO... --monohand BIN [--baseline BIN] --rounds R --out DIR
      the same clip at several frame sizes (one video per size): per size and round,
      MediaPipe `max_num_hands=1`, then monohand like for like (`--hands 1 --no-heads
      --no-mirror-pass`) and with its defaults, each also with the baseline binary when
      given (e.g. main's, "before"), alternating; one table of fps, ratios and `vision` ms
      per frame, with the load average before each round (also DIR/sizes.md).

Timing:
  * MediaPipe: `Hands(...)` is constructed first (graph and models loaded, not timed); the
    clock then runs from opening the video with cv2.VideoCapture to the last frame's result:
    decoding, BGR->RGB conversion and `process()` of every frame.
  * monohand: the frames-per-second of its summary line on stderr, which is timed from after
    the models are loaded and the video opened to the last record written: decoding
    (ffmpeg, in its own process), networks, 3D fit and JSON output of every frame.
  * CPU: MediaPipe's process CPU time over the timed loop (all its threads);
    monohand's CPU time (all threads plus its ffmpeg decoder) from rusage of the child,
    minus that of a 1-frame run (model loading and start-up), per frame.
  Both get the whole machine (no pinning) unless --cpus is given, in which case every run
  is started under `taskset -c CPUS`.
"""
import argparse
import json
import math
import os
import re
import resource
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))

# (name, max_num_hands) for MediaPipe; (name, extra args) for monohand.
MEDIAPIPE_RUNS = [
    ("mediapipe max_num_hands=2", 2),
    ("mediapipe max_num_hands=1", 1),
]
MONOHAND_RUNS = [
    ("monohand run (defaults: tracking, detector every 10 frames)", []),
    ("monohand run --detect-every 1", ["--detect-every", "1"]),
    # Like for like with MediaPipe, which reads each crop once: no mirror pass.
    ("monohand run --hands 2 --no-heads --detect-every 1 --no-mirror-pass",
     ["--hands", "2", "--no-heads", "--detect-every", "1", "--no-mirror-pass"]),
    ("monohand run --hands 1 --no-heads --no-mirror-pass", ["--hands", "1", "--no-heads", "--no-mirror-pass"]),
    ("monohand run --hands 1 --no-heads", ["--hands", "1", "--no-heads"]),
    ("monohand run --no-track", ["--no-track"]),
    # The same two like-for-like runs with the networks in int8 (issue 46).
    ("monohand run --hands 2 --no-heads --detect-every 1 --no-mirror-pass --precision int8",
     ["--hands", "2", "--no-heads", "--detect-every", "1", "--no-mirror-pass", "--precision", "int8"]),
    ("monohand run --hands 1 --no-heads --no-mirror-pass --precision int8",
     ["--hands", "1", "--no-heads", "--no-mirror-pass", "--precision", "int8"]),
]
# Which monohand run is compared with which MediaPipe run (same detector schedule).
PAIRS = [
    ("monohand run --hands 2 --no-heads --detect-every 1 --no-mirror-pass", "mediapipe max_num_hands=2",
     "palm detector + landmarks every frame, tracking crops"),
    ("monohand run --hands 1 --no-heads --no-mirror-pass", "mediapipe max_num_hands=1",
     "landmarks from tracking crops, detector only when the hand is lost"),
    ("monohand run (defaults: tracking, detector every 10 frames)", "mediapipe max_num_hands=2",
     "defaults of each (monohand tracking vs the brief's MediaPipe setting)"),
    ("monohand run --hands 2 --no-heads --detect-every 1 --no-mirror-pass --precision int8",
     "mediapipe max_num_hands=2", "palm detector + landmarks every frame, tracking crops, int8"),
    ("monohand run --hands 1 --no-heads --no-mirror-pass --precision int8", "mediapipe max_num_hands=1",
     "landmarks from tracking crops, detector only when the hand is lost, int8"),
]


def run_mediapipe(args):
    import cv2
    import mediapipe as mp

    hands = mp.solutions.hands.Hands(
        static_image_mode=False,
        max_num_hands=args.max_hands,
        model_complexity=1,
        min_detection_confidence=0.5,
        min_tracking_confidence=0.5,
    )
    frames = []
    cpu0 = time.process_time()
    t0 = time.perf_counter()
    cap = cv2.VideoCapture(args.video)
    if not cap.isOpened():
        raise SystemExit(f"cv2 cannot open {args.video}")
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        h, w = bgr.shape[:2]
        res = hands.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        found = []
        if res.multi_hand_landmarks:
            for lm, hd in zip(res.multi_hand_landmarks, res.multi_handedness):
                # Normalized [0,1] image coordinates -> monohand's pixel-centre convention.
                found.append({
                    "side": hd.classification[0].label,
                    "score": hd.classification[0].score,
                    "keypoints_2d": [[p.x * w - 0.5, p.y * h - 0.5] for p in lm.landmark],
                })
        frames.append(found)
    secs = time.perf_counter() - t0
    cpu = time.process_time() - cpu0
    cap.release()
    hands.close()
    if args.out:
        with open(args.out, "w") as f:
            json.dump(frames, f)
    print(json.dumps({"frames": len(frames), "seconds": secs, "fps": len(frames) / secs,
                      "cpu_s": cpu}))


def taskset(cmd, cpus):
    return ["taskset", "-c", cpus] + cmd if cpus else cmd


def child_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed(cmd):
    c0, t0 = child_cpu(), time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, child_cpu() - c0
    if p.returncode != 0:
        sys.stderr.write(p.stdout + p.stderr)
        raise SystemExit(f"failed: {' '.join(cmd)}")
    return p, wall, cpu


def mediapipe_once(a, max_hands, out):
    cmd = taskset([sys.executable, os.path.abspath(__file__), "mediapipe", a.video,
                   "--max-hands", str(max_hands), "--out", out], a.cpus)
    p, _, _ = timed(cmd)
    line = [l for l in p.stdout.splitlines() if l.startswith("{")][-1]
    r = json.loads(line)
    return {"fps": r["fps"], "frames": r["frames"], "cpu_ms": 1e3 * r["cpu_s"] / r["frames"]}


SUMMARY = re.compile(r"(\d+) frames \(.*?, ([0-9.]+) fps")


def monohand_once(a, extra, out, startup_cpu):
    cmd = taskset([a.monohand, "run", a.video, "-o", out] + extra, a.cpus)
    p, wall, cpu = timed(cmd)
    m = SUMMARY.search(p.stderr)
    if not m:
        raise SystemExit(f"no summary line in monohand's stderr:\n{p.stderr}")
    n = int(m.group(1))
    return {"fps": float(m.group(2)), "frames": n, "wall_s": wall,
            "cpu_ms": 1e3 * (cpu - startup_cpu) / max(1, n - 1)}


def monohand_startup_cpu(a, out):
    _, _, cpu = timed(taskset([a.monohand, "run", a.video, "-o", out, "--max-frames", "1"], a.cpus))
    return cpu


def load_monohand(path):
    frames, timings = [], []
    with open(path) as f:
        for line in f:
            rec = json.loads(line)
            frames.append([{"side": h.get("side"),
                            "keypoints_2d": [k[:2] for k in h["keypoints_2d"]]}
                           for h in rec.get("hands", [])])
            timings.append(rec.get("timings_ms") or {})
    return frames, timings


def roi_from_landmarks(lm):
    """MediaPipe's tracking crop from a hand's landmarks (HandLandmarksToRect + scale 2,
    square; our `roi_from_landmarks`): (rotation in radians, side in pixels)."""
    x0, y0 = lm[0]
    x1 = ((lm[6][0] + lm[14][0]) / 2 + lm[10][0]) / 2
    y1 = ((lm[6][1] + lm[14][1]) / 2 + lm[10][1]) / 2
    rot = math.pi / 2 - math.atan2(-(y1 - y0), x1 - x0)
    s, c = math.sin(rot), math.cos(rot)
    r = [(c * lm[j][0] + s * lm[j][1], -s * lm[j][0] + c * lm[j][1])
         for j in [0, 1, 2, 3, 5, 6, 9, 10, 13, 14, 17, 18]]
    w = max(a for a, _ in r) - min(a for a, _ in r)
    h = max(b for _, b in r) - min(b for _, b in r)
    return rot, 2 * max(w, h)


def convention_offset(prev_lm):
    """The offset (ours - MediaPipe, px) that two half-pixel conventions predict for a crop
    made from `prev_lm` (docs/performance.md): (+0.5, +0.5) from MediaPipe's CPU x*W being
    a pixel index already, and -0.5 (side/224) R(rotation) (1, 1) from its crop corners
    mapped to crop pixel indices 0 and 224."""
    rot, side = roi_from_landmarks(prev_lm)
    k = 0.5 * side / 224
    c, s = math.cos(rot), math.sin(rot)
    return 0.5 - k * (c - s), 0.5 - k * (s + c)


def compare_keypoints(ours, theirs, max_wrist_px=60.0):
    """Per matched hand: mean over the 21 joints of the 2D distance; matched greedily by
    wrist distance (at most max_wrist_px)."""
    dists, dx, dy, per_joint = [], [], [], [[] for _ in range(21)]
    corrected, per_joint_corrected = [], [[] for _ in range(21)]
    only_ours = only_theirs = 0
    prev = None
    for fo, ft in zip(ours, theirs):
        pairs = sorted(
            (math.dist(o["keypoints_2d"][0], t["keypoints_2d"][0]), i, j)
            for i, o in enumerate(fo) for j, t in enumerate(ft))
        used_o, used_t = set(), set()
        for d, i, j in pairs:
            if d > max_wrist_px or i in used_o or j in used_t:
                continue
            used_o.add(i)
            used_t.add(j)
            ko, kt = fo[i]["keypoints_2d"], ft[j]["keypoints_2d"]
            e = [math.dist(p, q) for p, q in zip(ko, kt)]
            for k in range(21):
                per_joint[k].append(e[k])
            dists.append(sum(e) / 21)
            dx.append(sum(p[0] - q[0] for p, q in zip(ko, kt)) / 21)
            dy.append(sum(p[1] - q[1] for p, q in zip(ko, kt)) / 21)
            # With one hand in consecutive frames, its crop came from MediaPipe's previous
            # landmarks: remove the offset the conventions predict for that crop.
            if prev is not None and len(ft) == 1 and len(prev) == 1:
                ox, oy = convention_offset(prev[0]["keypoints_2d"])
                e = [math.hypot(p[0] - q[0] - ox, p[1] - q[1] - oy) for p, q in zip(ko, kt)]
                corrected.append(sum(e) / 21)
                for k in range(21):
                    per_joint_corrected[k].append(e[k])
        prev = ft
        only_ours += len(fo) - len(used_o)
        only_theirs += len(ft) - len(used_t)
    return {"matched": len(dists), "only_ours": only_ours, "only_theirs": only_theirs,
            "dists": dists, "dx": dx, "dy": dy, "per_joint": per_joint,
            "corrected": corrected, "per_joint_corrected": per_joint_corrected}


def pct(xs, q):
    if not xs:
        return float("nan")
    s = sorted(xs)
    return s[min(len(s) - 1, int(math.ceil(q * len(s))) - 1)]


def run_compare(a):
    os.makedirs(a.out, exist_ok=True)
    results = {name: [] for name, _ in MEDIAPIPE_RUNS + MONOHAND_RUNS}
    startup = []
    for r in range(a.rounds):
        s = monohand_startup_cpu(a, os.path.join(a.out, "startup.jsonl"))
        startup.append(s)
        for k in range(max(len(MEDIAPIPE_RUNS), len(MONOHAND_RUNS))):
            # Alternate: MediaPipe, monohand, MediaPipe, monohand, ...
            if k < len(MEDIAPIPE_RUNS):
                name, mh = MEDIAPIPE_RUNS[k]
                res = mediapipe_once(a, mh, os.path.join(a.out, f"mp{mh}.json"))
                results[name].append(res)
                print(f"round {r + 1}: {name}: {res['fps']:.1f} fps", file=sys.stderr)
            if k < len(MONOHAND_RUNS):
                name, extra = MONOHAND_RUNS[k]
                res = monohand_once(a, extra, os.path.join(a.out, f"monohand{k}.jsonl"), s)
                results[name].append(res)
                print(f"round {r + 1}: {name}: {res['fps']:.1f} fps", file=sys.stderr)
            # The remaining monohand runs (more monohand than MediaPipe configurations)
            # still alternate with the round's MediaPipe runs above.
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump({"rounds": results, "startup_cpu_s": startup}, f, indent=1)
    report = make_report(a, results, startup)
    with open(os.path.join(a.out, "report.md"), "w") as f:
        f.write(report)
    print(report)


def make_report(a, results, startup):
    med = {k: statistics.median(x["fps"] for x in v) for k, v in results.items()}
    lines = []
    lines.append(f"Video: {a.video}, {results[MEDIAPIPE_RUNS[0][0]][0]['frames']} frames; "
                 f"{a.rounds} rounds; CPUs: {a.cpus or 'all (no pinning)'}; "
                 f"monohand start-up CPU (1-frame run): {statistics.median(startup):.2f} s\n")
    lines.append("| run | fps (median) | fps per round | CPU ms / frame (median) |")
    lines.append("|---|---|---|---|")
    for name in [n for n, _ in MEDIAPIPE_RUNS + MONOHAND_RUNS]:
        rs = results[name]
        lines.append(f"| {name} | {med[name]:.1f} | "
                     f"{' / '.join('%.1f' % x['fps'] for x in rs)} | "
                     f"{statistics.median(x['cpu_ms'] for x in rs):.1f} |")
    lines.append("")
    lines.append("| monohand run | MediaPipe run | what both do | fps ratio monohand / MediaPipe "
                 "| mean 2D disagreement (px) | median | 95th pct | max | mean offset dx, dy (px) "
                 "| mean after removing the half-pixel conventions (px) | 95th pct "
                 "| hands matched / only monohand / only MediaPipe |")
    lines.append("|---|---|---|---|---|---|---|---|---|---|---|---|")
    mono_names = [n for n, _ in MONOHAND_RUNS]
    mp_files = {n: f"mp{mh}.json" for n, mh in MEDIAPIPE_RUNS}
    for ours, theirs, what in PAIRS:
        k = mono_names.index(ours)
        frames, _ = load_monohand(os.path.join(a.out, f"monohand{k}.jsonl"))
        with open(os.path.join(a.out, mp_files[theirs])) as f:
            mp = json.load(f)
        c = compare_keypoints(frames, mp)
        d = c["dists"]
        mean = lambda xs: sum(xs) / len(xs) if xs else float("nan")
        lines.append(
            f"| `{ours.replace('monohand run', '').strip() or 'defaults'}` | `{theirs.replace('mediapipe ', '')}` | {what} | "
            f"{med[ours] / med[theirs]:.2f} | {mean(d):.2f} | {pct(d, 0.5):.2f} | {pct(d, 0.95):.2f} | "
            f"{max(d) if d else float('nan'):.2f} | {mean(c['dx']):+.2f}, {mean(c['dy']):+.2f} | "
            f"{mean(c['corrected']):.2f} | {pct(c['corrected'], 0.95):.2f} | "
            f"{c['matched']} / {c['only_ours']} / {c['only_theirs']} |")
        if ours == PAIRS[0][0]:
            pj = [mean(x) for x in c["per_joint"]]
            pjc = [mean(x) for x in c["per_joint_corrected"]]
            per_joint_line = ("Mean disagreement per joint (px, wrist first), first pair: "
                              + ", ".join(f"{x:.1f}" for x in pj)
                              + "; after removing the half-pixel conventions: "
                              + ", ".join(f"{x:.1f}" for x in pjc))
    lines.append("")
    lines.append(per_joint_line)
    # Runs that produce the very same keypoints (e.g. the detector's extra regions are all
    # dropped as duplicates of the tracked hand) make the rows above equal; say so.
    kp = {n: load_monohand(os.path.join(a.out, f"monohand{k}.jsonl"))[0]
          for k, n in enumerate(mono_names)}
    same = [n for n in mono_names[1:] if kp[n] == kp[mono_names[0]]]
    lines.append("")
    lines.append(f"monohand runs with keypoints identical to `{mono_names[0]}`: "
                 + (", ".join(f"`{n}`" for n in same) or "none"))
    mps = {}
    for n, _ in MEDIAPIPE_RUNS:
        with open(os.path.join(a.out, mp_files[n])) as f:
            mps[n] = json.load(f)
    first = MEDIAPIPE_RUNS[0][0]
    same = [n for n, _ in MEDIAPIPE_RUNS[1:] if mps[n] == mps[first]]
    lines.append(f"MediaPipe runs with landmarks identical to `{first}`: "
                 + (", ".join(f"`{n}`" for n in same) or "none"))
    lines.append("")
    lines.append("Stage times from monohand's `timings_ms` (mean ms per frame, last round; "
                 "the three stages run on different threads and overlap):")
    lines.append("")
    lines.append("| monohand run | decode | vision (networks) | fit (3D) | sum | vision on frames ≥ 2x the median (count, mean) |")
    lines.append("|---|---|---|---|---|---|")
    for k, name in enumerate(mono_names):
        _, tim = load_monohand(os.path.join(a.out, f"monohand{k}.jsonl"))
        cols = []
        for stage in ["decode", "vision", "fit"]:
            xs = [t[stage] for t in tim if stage in t]
            cols.append(sum(xs) / len(xs) if xs else float("nan"))
        vis = [t["vision"] for t in tim if "vision" in t]
        mv = statistics.median(vis)
        slow = [v for v in vis if v >= 2 * mv]
        slow_s = f"{len(slow)}, {sum(slow) / len(slow):.1f}" if slow else "0"
        lines.append(f"| `{name.replace('monohand run', '').strip()}` | {cols[0]:.2f} | {cols[1]:.2f} | "
                     f"{cols[2]:.2f} | {sum(cols):.2f} | {slow_s} |")
    lines.append("")
    return "\n".join(lines)


LIKE_FOR_LIKE = ["--hands", "1", "--no-heads", "--no-mirror-pass"]


def frame_size(video):
    p = subprocess.run(["ffprobe", "-v", "error", "-select_streams", "v:0", "-show_entries",
                        "stream=width,height", "-of", "csv=p=0", video],
                       capture_output=True, text=True, check=True)
    w, h = p.stdout.strip().split(",")[:2]
    return f"{w}x{h}"


def mean_vision_ms(path):
    _, tim = load_monohand(path)
    vis = [t["vision"] for t in tim if "vision" in t]
    return sum(vis) / len(vis) if vis else float("nan")


def run_sizes(a):
    os.makedirs(a.out, exist_ok=True)
    bins = [("after", a.monohand)] + ([("before", a.baseline)] if a.baseline else [])
    rows = {}
    for video in a.videos:
        size = frame_size(video)
        r = rows[size] = {"video": video, "load": [], "mp": [], "runs": {}}
        startup = {}
        for label, binary in bins:
            b = argparse.Namespace(monohand=binary, video=video, cpus=a.cpus)
            startup[label] = monohand_startup_cpu(b, os.path.join(a.out, "startup.jsonl"))
        for k in range(a.rounds):
            r["load"].append(os.getloadavg()[0])
            mp = mediapipe_once(argparse.Namespace(video=video, cpus=a.cpus), 1,
                                os.path.join(a.out, f"mp1_{size}.json"))
            r["mp"].append(mp["fps"])
            print(f"{size} round {k + 1}: mediapipe max_num_hands=1: {mp['fps']:.1f} fps",
                  file=sys.stderr)
            # Alternate the binaries within each configuration, the first of them by round.
            order = bins if k % 2 == 0 else bins[::-1]
            for mode, extra in [("like for like", LIKE_FOR_LIKE), ("defaults", [])]:
                for label, binary in order:
                    b = argparse.Namespace(monohand=binary, video=video, cpus=a.cpus)
                    out = os.path.join(a.out, f"{label}_{mode.replace(' ', '_')}_{size}.jsonl")
                    res = monohand_once(b, extra, out, startup[label])
                    res["vision_ms"] = mean_vision_ms(out)
                    r["runs"].setdefault((label, mode), []).append(res)
                    print(f"{size} round {k + 1}: {label} {mode}: {res['fps']:.1f} fps, "
                          f"vision {res['vision_ms']:.1f} ms", file=sys.stderr)
    lines = [f"{a.rounds} rounds per size, alternating; CPUs: {a.cpus or 'all (no pinning)'}; "
             "fps are medians over rounds, `vision` the median over rounds of the mean ms per "
             "frame of monohand's vision stage.", ""]
    head = "| frame size | load (1 min) | MediaPipe `max_num_hands=1` |"
    sep = "|---|---|---|"
    for label, _ in bins:
        head += (f" {label}: like for like | ratio | {label}: defaults |"
                 f" {label}: `vision` ms, like for like | {label}: `vision` ms, defaults |"
                 f" {label}: CPU ms / frame, like for like | {label}: CPU ms / frame, defaults |")
        sep += "---|---|---|---|---|---|---|"
    lines += [head, sep]
    summary = {}
    for size, r in rows.items():
        mp = statistics.median(r["mp"])
        line = (f"| {size} | {min(r['load']):.1f}-{max(r['load']):.1f} | {mp:.1f} "
                f"({' / '.join('%.1f' % x for x in r['mp'])}) |")
        summary[size] = {"mediapipe_fps": r["mp"], "load": r["load"]}
        for label, _ in bins:
            lfl, dft = r["runs"][(label, "like for like")], r["runs"][(label, "defaults")]
            f1 = statistics.median(x["fps"] for x in lfl)
            f2 = statistics.median(x["fps"] for x in dft)
            v1 = statistics.median(x["vision_ms"] for x in lfl)
            v2 = statistics.median(x["vision_ms"] for x in dft)
            c1 = statistics.median(x["cpu_ms"] for x in lfl)
            c2 = statistics.median(x["cpu_ms"] for x in dft)
            line += (f" {f1:.1f} ({' / '.join('%.1f' % x['fps'] for x in lfl)}) | {f1 / mp:.2f} |"
                     f" {f2:.1f} ({' / '.join('%.1f' % x['fps'] for x in dft)}) | {v1:.1f} | {v2:.1f} |"
                     f" {c1:.1f} | {c2:.1f} |")
            summary[size][label] = {"like for like": lfl, "defaults": dft}
        lines.append(line)
    report = "\n".join(lines) + "\n"
    with open(os.path.join(a.out, "sizes.json"), "w") as f:
        json.dump(summary, f, indent=1)
    with open(os.path.join(a.out, "sizes.md"), "w") as f:
        f.write(report)
    print(report)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    m = sub.add_parser("mediapipe")
    m.add_argument("video")
    m.add_argument("--max-hands", type=int, default=2)
    m.add_argument("--out")
    c = sub.add_parser("compare")
    c.add_argument("video")
    c.add_argument("--monohand", required=True)
    c.add_argument("--rounds", type=int, default=3)
    c.add_argument("--out", required=True)
    c.add_argument("--cpus", help="run everything under taskset -c CPUS (e.g. 0)")
    z = sub.add_parser("sizes")
    z.add_argument("videos", nargs="+")
    z.add_argument("--monohand", required=True)
    z.add_argument("--baseline", help="a second monohand binary (e.g. main's), run alike")
    z.add_argument("--rounds", type=int, default=3)
    z.add_argument("--out", required=True)
    z.add_argument("--cpus", help="run everything under taskset -c CPUS (e.g. 0)")
    a = ap.parse_args()
    if a.cmd == "mediapipe":
        run_mediapipe(a)
    elif a.cmd == "sizes":
        a.videos = [os.path.abspath(v) for v in a.videos]
        run_sizes(a)
    else:
        a.video = os.path.abspath(a.video)
        run_compare(a)


if __name__ == "__main__":
    main()
