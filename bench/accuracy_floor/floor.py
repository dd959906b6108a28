#!/usr/bin/env python3
"""How well can the population hand model match real 3D labels at all?

The fit's output is always a posed default skeleton, so its shape error has a floor
that no cue can remove: the error left when the fit is given *perfect* inputs. This
script measures that floor on the hand-graph-cnn development set, next to the real
fit, with `monohand lift` (the same fitter as `run`):

- `network`: the landmark network's 2D keypoints, world landmarks and relative depth
  (from `monohand detect`), lifted with the defaults: what `run` does (with depth
  fusion, docs/accuracy.md), and once without depth fusion;
- `perfect 2D`: the labels projected into the camera, no 3D cue (the paper's cost
  with ideal keypoints);
- `floor`: the labels projected, plus the labels' own 3D as the metric cue, weight 20
  (the fit then follows the true bone directions as far as the skeleton allows);
- the same two with the subject's median bone lengths (`--bone-lengths`), which shows
  whether the lengths or the rest of the skeleton (palm layout, axes) limit the floor;
- and it prints, bone by bone, the network's 2D bone lengths against the labels'
  (what a bundle adjustment of bone lengths over the 2D keypoints would learn).

    monohand detect ../shared/data/hand_graph_cnn_dev/images -o /tmp/dev.jsonl
    python3 bench/accuracy_floor/floor.py /tmp/dev.jsonl \
        ../shared/data/hand_graph_cnn_dev/labels.json target/release/monohand

Needs numpy (for the Procrustes alignment). Writes its lift inputs and outputs to a
temporary folder. The numbers are in docs/accuracy.md.
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

PARENT = [None, 0, 1, 2, 3, 0, 5, 6, 7, 0, 9, 10, 11, 0, 13, 14, 15, 0, 17, 18, 19]
NAMES = ["wrist"] + [f"{f}{k}" for f in ("thumb", "index", "middle", "ring", "little") for k in range(1, 5)]


def pa_errors(p, g):
    """Per-joint distance after the similarity transform that best aligns p to g."""
    mp, mg = p.mean(0), g.mean(0)
    P, Q = p - mp, g - mg
    U, S, Vt = np.linalg.svd(P.T @ Q)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    R = U @ D @ Vt
    s = (S * np.diag(D)).sum() / (P**2).sum()
    return np.linalg.norm(s * P @ R - Q, axis=1)


def score(path, gt):
    rows = []
    for line in open(path):
        r = json.loads(line)
        hands = [h for h in r["hands"] if h.get("joints_3d_mm")]
        if not hands:
            continue
        p, g = np.array(hands[0]["joints_3d_mm"]), gt[r["frame"]]
        rows.append(
            (
                np.linalg.norm(p - g, axis=1).mean(),
                np.linalg.norm((p - p[0]) - (g - g[0]), axis=1).mean(),
                np.linalg.norm((p - p.mean(0)) - (g - g.mean(0)), axis=1).mean(),
                pa_errors(p, g),
            )
        )
    per_joint = np.mean([r[3] for r in rows], axis=0)
    return len(rows), [np.mean([r[i] for r in rows]) for i in range(3)] + [per_joint.mean()], per_joint


def main():
    detections, labels_path, binary = sys.argv[1:4]
    labels = json.load(open(labels_path))
    cam = labels["camera"]
    frames = labels["frames"]
    gt = {f["frame"]: np.array(f["joints_3d_mm"]) for f in frames}
    det = {}
    for line in open(detections):
        r = json.loads(line)
        det[os.path.basename(r["source"]) if "source" in r else r["frame"]] = r
    tmp = tempfile.mkdtemp(prefix="monohand-floor-")
    cam_path = os.path.join(tmp, "camera.json")
    json.dump({k: cam[k] for k in ("fx", "fy", "cx", "cy", "width", "height")}, open(cam_path, "w"))

    # Lift inputs in the full 1280x720 camera: the crops' keypoints mapped back.
    net_rows, gt_rows, ratios = [], [], {j: [] for j in range(1, 21)}
    for i, f in enumerate(frames):
        x, y, w, _ = f["crop_box_xywh"]
        s = 256.0 / w
        g = gt[f["frame"]]
        proj = g / g[:, 2:]
        gt2 = np.stack([cam["fx"] * proj[:, 0] + cam["cx"], cam["fy"] * proj[:, 1] + cam["cy"]], 1)
        gt_rows.append(
            {
                "frame": f["frame"],
                "hands": [
                    {
                        "side": "left",
                        "keypoints_2d": np.column_stack([gt2, np.ones(21)]).tolist(),
                        "world_mm": (g - g.mean(0)).tolist(),
                    }
                ],
            }
        )
        r = det.get(os.path.basename(f["image"]), det.get(i))
        hands = []
        if r and r.get("hands"):
            h = r["hands"][0]
            kp = np.array(h["keypoints_2d"], dtype=float)
            kp[:, 0] = kp[:, 0] / s + x
            kp[:, 1] = kp[:, 1] / s + y
            hand = {"side": "left", "keypoints_2d": kp.tolist()}
            if h.get("world_mm"):
                hand["world_mm"] = h["world_mm"]
            if h.get("depth_px"):
                hand["depth_px"] = (np.array(h["depth_px"]) / s).tolist()
            hands.append(hand)
            for j in range(1, 21):
                lg = np.linalg.norm(gt2[j] - gt2[PARENT[j]])
                if lg > 15.0:  # skip bones seen end-on
                    ratios[j].append(np.linalg.norm(kp[j, :2] - kp[PARENT[j], :2]) / lg)
        net_rows.append({"frame": f["frame"], "hands": hands})
    for name, rows in (("net", net_rows), ("gt", gt_rows)):
        with open(os.path.join(tmp, name + ".jsonl"), "w") as o:
            for r in rows:
                o.write(json.dumps(r) + "\n")
    all_gt = np.array([gt[f["frame"]] for f in frames])
    lengths = [float(np.median(np.linalg.norm(all_gt[:, j] - all_gt[:, PARENT[j]], axis=1))) for j in range(1, 21)]
    len_path = os.path.join(tmp, "subject_lengths.json")
    json.dump(lengths, open(len_path, "w"))

    # The floor is the posed skeleton's: depth fusion (which would take the labels' own
    # depths from the "true 3D" cue) is off in its rows.
    skeleton_only = ["--fuse-world", "0", "--fuse-depth", "0"]
    runs = [
        ("network cues, default skeleton (what `run` does, depth fusion on)", "net", []),
        ("network cues, default skeleton, no depth fusion", "net", skeleton_only),
        ("network cues, subject's bone lengths", "net", ["--bone-lengths", len_path] + skeleton_only),
        ("perfect 2D, no 3D cue, default skeleton", "gt", ["--world-weight", "0", "--depth-weight", "0"]),
        ("floor: perfect 2D + true 3D directions, default skeleton", "gt", ["--world-weight", "20"] + skeleton_only),
        ("floor with the subject's bone lengths", "gt", ["--world-weight", "20", "--bone-lengths", len_path] + skeleton_only),
    ]
    print("| input and skeleton | frames | absolute | wrist-relative | centroid | PA-MPJPE |")
    print("|---|---|---|---|---|---|")
    per_joint = {}
    for label, inp, extra in runs:
        out = os.path.join(tmp, f"out-{len(per_joint)}.jsonl")
        cmd = [binary, "lift", "--camera", cam_path, "--jsonl", os.path.join(tmp, inp + ".jsonl"), "--track", "-q", "-o", out] + extra
        subprocess.run(cmd, check=True)
        n, m, pj = score(out, gt)
        per_joint[label] = pj
        print(f"| {label} | {n} | {m[0]:.2f} | {m[1]:.2f} | {m[2]:.2f} | {m[3]:.2f} |")
    print("\nPA-MPJPE per joint (mm):")
    print("| run | " + " | ".join(NAMES) + " |")
    print("|---|" + "---|" * 21)
    for label, pj in per_joint.items():
        print(f"| {label} | " + " | ".join(f"{v:.0f}" for v in pj) + " |")
    print("\nThe network's 2D bone lengths over the labels' (median, bones longer than 15 px):")
    print("| bone | " + " | ".join(f"{NAMES[PARENT[j]]}-{NAMES[j]}" for j in range(1, 21)) + " |")
    print("|---|" + "---|" * 20)
    print("| ratio | " + " | ".join(f"{np.median(ratios[j]):.2f}" for j in range(1, 21)) + " |")


if __name__ == "__main__":
    main()
