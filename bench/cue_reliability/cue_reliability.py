#!/usr/bin/env python3
"""How far the landmark network's 3D cues can be trusted, bone by bone.

Compares the direction of every bone in MediaPipe's world landmarks (`world_mm`) and in
its relative depth (`depth_px` with the 2D keypoints) against the 3D labels of the
hand-graph-cnn development set, after the same optical-axis-to-viewing-ray turn the fit
applies. Prints the angular error per bone, per confidence level (the smaller of the two
joints' confidences) and per place in the finger: the last table is
`monohand_core::fitting::CUE_BONE_ERROR_DEG`.

    monohand detect ../shared/data/hand_graph_cnn_dev/images -o /tmp/dev.jsonl
    python3 bench/cue_reliability/cue_reliability.py /tmp/dev.jsonl \
        ../shared/data/hand_graph_cnn_dev/labels.json

Plain Python, no packages.
"""
import json
import math
import sys

# Finger by finger, base to tip: the order of monohand_core::hand_model::BONES.
BONES = [(0 if k == 0 else 4 * f + k, 4 * f + k + 1) for f in range(5) for k in range(4)]
SEGMENTS = ["wrist-base", "proximal", "middle", "distal"]
CONF_BINS = [0.0, 0.5, 0.8, 1.01]


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def unit(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a] if n > 0 else None


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def turn_to(ray):
    """Rotation taking the optical axis (0, 0, 1) to `ray` (Rodrigues)."""
    b = unit(ray)
    v = [-b[1], b[0], 0.0]  # z x b
    c = b[2]
    vx = [[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]]
    vx2 = [[sum(vx[i][k] * vx[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    f = 1.0 / (1.0 + c)
    return [[(i == j) + vx[i][j] + vx2[i][j] * f for j in range(3)] for i in range(3)]


def rms(v):
    return math.sqrt(sum(e * e for e in v) / len(v)) if v else float("nan")


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    labels = json.load(open(sys.argv[2]))
    cam = labels["camera"]
    frames = {f["image"].split("/")[-1]: f for f in labels["frames"]}
    errors = {}  # (cue, bone) -> [(degrees, confidence)]
    used = 0
    for line in open(sys.argv[1]):
        rec = json.loads(line)
        f = frames.get(rec["source"])
        if f is None or not rec["hands"]:
            continue
        hand = max(rec["hands"], key=lambda h: h.get("score", 0.0))
        kp, world, depth = hand["keypoints_2d"], hand.get("world_mm"), hand.get("depth_px")
        x, y, w, _ = f["crop_box_xywh"]
        s = rec["image_size"][0] / w
        fx, fy = cam["fx"] * s, cam["fy"] * s
        cx, cy = (cam["cx"] - x) * s, (cam["cy"] - y) * s
        seen = [k for k in kp if k[2] > 0]
        if not seen:
            continue
        used += 1
        mu = sum(k[0] for k in seen) / len(seen)
        mv = sum(k[1] for k in seen) / len(seen)
        turn = turn_to([(mu - cx) / fx, (mv - cy) / fy, 1.0])
        truth = f["joints_3d_mm"]
        for b, (p, c) in enumerate(BONES):
            g = unit(sub(truth[c], truth[p]))
            conf = min(kp[p][2], kp[c][2])
            cues = {
                "world": sub(world[c], world[p]) if world else None,
                "depth": [(kp[c][0] - kp[p][0]) / fx, (kp[c][1] - kp[p][1]) / fy,
                          (depth[c] - depth[p]) / fx] if depth else None,
            }
            for cue, d in cues.items():
                d = unit([dot(r, d) for r in turn]) if d else None
                if d and g:
                    e = math.degrees(math.acos(max(-1.0, min(1.0, dot(d, g)))))
                    errors.setdefault((cue, b), []).append((e, conf))
    print(f"{used} frames with a hand; angular error of the bone directions, degrees")
    head = " | ".join(f"rms, conf {lo:.1f}-{min(hi, 1.0):.1f} (n)" for lo, hi in zip(CONF_BINS, CONF_BINS[1:]))
    for cue in ["world", "depth"]:
        print(f"\n{cue}: | bone | median | rms | {head} |")
        for b, bone in enumerate(BONES):
            v = errors.get((cue, b), [])
            es = sorted(e for e, _ in v)
            bins = " | ".join(
                f"{rms([e for e, p in v if lo <= p < hi]):5.1f} ({sum(1 for _, p in v if lo <= p < hi)})"
                for lo, hi in zip(CONF_BINS, CONF_BINS[1:]))
            med = es[len(es) // 2] if es else float("nan")
            print(f"| {bone} | {med:5.1f} | {rms(es):5.1f} | {bins} |")
    print("\nrms by place in the finger (the five fingers pooled):")
    for cue in ["world", "depth"]:
        row = [rms([e for b in range(s, 20, 4) for e, _ in errors.get((cue, b), [])]) for s in range(4)]
        print(f"| {cue} | " + " | ".join(f"{SEGMENTS[s]} {row[s]:.1f}" for s in range(4)) + " |")


if __name__ == "__main__":
    main()
