#!/usr/bin/env python3
"""Retargets `monohand run --wrist-pose` records to robot hands with dex-retargeting's own
configs, and says how well (bench/retargeting/README.md).

    python retarget.py RECORDS.jsonl --out DIR [--robots allegro inspire]

For each robot hand (Allegro, Inspire; URDFs from ../shared/data/robot_hands) and each mode:

- vector: dex-retargeting's teleop config, fed the joints in the wrist frame
  (`wrist_pose`'s MANO frame, metres): the robot's wrist-to-fingertip vectors against the
  hand's, times the config's scaling factor;
- position: its offline config, whose robot floats on six dummy joints, fed the joints
  absolute (metres, the camera's frame), the robot's root started at the record's wrist pose:
  the robot's fingertips against the hand's, and where the robot's wrist ends up against
  monohand's wrist pose.

Writes DIR/<robot>_joints.png (the robot's joint angles over time, both modes) and
DIR/summary.json, and prints a Markdown table: the fingertip distance error after
retargeting, the share of frames within the URDF's joint limits, the time per frame; and,
for each frame, how far `wrist_pose`'s rotation is from dex-retargeting's own construction
from joints 0, 5 and 9 (an SVD and its `OPERATOR2MANO`).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from dex_retargeting.constants import OPERATOR2MANO_LEFT, OPERATOR2MANO_RIGHT  # noqa: E402
from dex_retargeting.retargeting_config import RetargetingConfig  # noqa: E402
from pytransform3d import rotations  # noqa: E402

import dex_retargeting  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
URDF_DIR = REPO.parent / "shared" / "data" / "robot_hands"
CONFIGS = Path(dex_retargeting.__file__).parent / "configs"
#: dex-retargeting's config folder for each mode.
MODES = {"vector": "teleop", "position": "offline"}
DUMMY = "dummy"
#: Joints within this of a URDF limit count as within it (float32 retargeting).
LIMIT_TOL = 1e-6
#: How far dex-retargeting's optimizer lets a joint go past its URDF limit
#: (`Optimizer.set_joint_limit`'s epsilon), rad.
OPTIMIZER_SLACK = 1e-3


def hands_of(records: Path):
    """Per frame, the first hand with 3D and a wrist pose: (frame, time, side, joints in
    metres in the camera's frame, the 4x4 wrist pose), or None."""
    out = []
    for line in records.read_text().splitlines():
        if not line.strip():
            continue
        rec = json.loads(line)
        hand = next((h for h in rec["hands"] if "wrist_pose" in h and "joints_3d_mm" in h), None)
        if hand is None:
            out.append(None)
            continue
        assert hand["wrist_pose"]["convention"] == "mano"
        out.append(
            (
                rec["frame"],
                rec.get("time_s", rec["frame"] / 30.0),
                hand["side"],
                np.array(hand["joints_3d_mm"]) / 1000.0,
                np.array(hand["wrist_pose"]["matrix_m"]),
            )
        )
    return out


def dex_frame(joints: np.ndarray, side: str) -> np.ndarray:
    """dex-retargeting's wrist frame from joints 0, 5 and 9 (its MediaPipe example's
    construction, re-derived), with its own OPERATOR2MANO: the axes as columns."""
    p = joints[[0, 5, 9]]
    x_vector = p[0] - p[2]
    _, _, vt = np.linalg.svd(p - p.mean(axis=0))
    normal = vt[2]
    x = x_vector - (x_vector @ normal) * normal
    x /= np.linalg.norm(x)
    z = np.cross(x, normal)
    if z @ (p[1] - p[2]) < 0:
        normal, z = -normal, -z
    o = OPERATOR2MANO_RIGHT if side == "right" else OPERATOR2MANO_LEFT
    return np.stack([x, normal, z], axis=1) @ o


def degrees_between(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(a.T @ b) - 1) / 2, -1, 1))))


def retarget(robot: str, mode: str, side: str, frames, frame: str = "monohand"):
    """One robot, one mode, over the frames. `frame`: the wrist frame the joints are given
    in, "monohand" (the records' `wrist_pose`) or "dex" (dex-retargeting's own SVD
    construction from the same joints 0, 5 and 9, at the wrist joint)."""
    RetargetingConfig.set_default_urdf_dir(str(URDF_DIR))
    config_path = CONFIGS / MODES[mode] / f"{robot}_hand_{side}.yml"
    config = RetargetingConfig.load_from_file(config_path)
    seq = config.build()
    opt = seq.optimizer
    wrapper = opt.robot
    names = wrapper.dof_joint_names
    limits = wrapper.joint_limits
    fixed = np.zeros(len(opt.idx_pin2fixed))
    indices = opt.target_link_human_indices
    if mode == "vector":
        origin = [wrapper.get_link_index(n) for n in config.target_origin_link_names]
        tips = [wrapper.get_link_index(n) for n in config.target_task_link_names]
        human_tips = indices[1]
        human_origin = indices[0]
    else:
        # The fingertip links are those that stand for the human fingertips (4, 8, ..., 20).
        keep = [k for k, j in enumerate(indices) if j in (4, 8, 12, 16, 20)]
        tips = [wrapper.get_link_index(config.target_link_names[k]) for k in keep]
        human_tips = indices[keep]
        wrist_link = wrapper.get_joint_parent_child_frames("dummy_z_rotation_joint")[1]
    qpos, tip_err, wrist_err_mm, wrist_err_deg, within, within_slack = [], [], [], [], [], []
    spent = 0.0
    warm = False
    for f in frames:
        if f is None:
            qpos.append(np.full(len(names), np.nan))
            continue
        _, _, _, joints, wrist = f
        r, t = wrist[:3, :3], wrist[:3, 3]
        if frame == "dex":
            r = dex_frame(joints, side)
        local = (joints - t) @ r  # the joints in the wrist frame, metres
        tic = time.perf_counter()
        if mode == "vector":
            ref = local[indices[1]] - local[indices[0]]
        else:
            if not warm:
                # The robot's root starts where monohand's wrist is (its wrist link in the
                # MANO frame, as the vector mode's robot base is).
                seq.warm_start(t, rotations.quaternion_from_matrix(r), is_mano_convention=False)
                warm = True
            ref = joints[indices]
        q = seq.retarget(ref, fixed)
        spent += time.perf_counter() - tic
        qpos.append(q)
        wrapper.compute_forward_kinematics(q)
        pose = {i: wrapper.get_link_pose(i) for i in set(tips) | set(origin if mode == "vector" else [wrist_link])}
        if mode == "vector":
            robot_vec = np.array([pose[b][:3, 3] - pose[a][:3, 3] for a, b in zip(origin, tips)])
            human_vec = (local[human_tips] - local[human_origin]) * config.scaling_factor
            tip_err.append(np.linalg.norm(robot_vec - human_vec, axis=1).mean())
        else:
            robot_tips = np.array([pose[b][:3, 3] for b in tips])
            tip_err.append(np.linalg.norm(robot_tips - joints[human_tips], axis=1).mean())
            w = pose[wrist_link]
            wrist_err_mm.append(1000.0 * np.linalg.norm(w[:3, 3] - t))
            wrist_err_deg.append(degrees_between(w[:3, :3], r))
        real = [k for k, n in enumerate(names) if not n.startswith(DUMMY)]
        for tol, out in [(LIMIT_TOL, within), (OPTIMIZER_SLACK + LIMIT_TOL, within_slack)]:
            ok = np.all((q[real] >= limits[real, 0] - tol) & (q[real] <= limits[real, 1] + tol))
            out.append(bool(ok))
    n = len(tip_err)
    result = {
        "robot": robot,
        "mode": mode,
        "wrist_frame": frame,
        "config": f"{MODES[mode]}/{config_path.name}",
        "frames": n,
        "fingertip_error_mm_mean": 1000.0 * float(np.mean(tip_err)),
        "fingertip_error_mm_median": 1000.0 * float(np.median(tip_err)),
        "within_limits_share": float(np.mean(within)),
        "within_limits_and_slack_share": float(np.mean(within_slack)),
        "ms_per_frame": 1000.0 * spent / max(n, 1),
    }
    if mode == "vector":
        result["scaling_factor"] = config.scaling_factor
    else:
        result["wrist_error_mm_median"] = float(np.median(wrist_err_mm))
        result["wrist_error_deg_median"] = float(np.median(wrist_err_deg))
    real = [k for k, n in enumerate(names) if not n.startswith(DUMMY)]
    return result, np.array(qpos)[:, real], [names[k] for k in real], limits[real]


def plot(robot: str, runs, times, out: Path) -> None:
    fig, axes = plt.subplots(len(runs), 1, figsize=(10, 3.2 * len(runs)), sharex=True)
    for ax, (mode, q, names, limits) in zip(np.atleast_1d(axes), runs):
        for k, name in enumerate(names):
            ax.plot(times, q[:, k], lw=1.0, label=name)
        ax.set_title(f"{robot} hand, {mode} retargeting")
        ax.set_ylabel("joint angle, rad")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, ncol=4, loc="upper right")
    np.atleast_1d(axes)[-1].set_xlabel("time, s")
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("records", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--robots", nargs="+", default=["allegro", "inspire"])
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    frames = hands_of(args.records)
    seen = [f for f in frames if f is not None]
    assert seen, f"{args.records}: no hand with a wrist pose (run monohand with --wrist-pose)"
    sides = [f[2] for f in seen]
    side = max(set(sides), key=sides.count)
    # Frames of the other side are left out (the configs are per side).
    frames = [f if f is not None and f[2] == side else None for f in frames]
    times = np.array([f[1] if f is not None else np.nan for f in frames])
    times = np.where(np.isnan(times), np.arange(len(frames)) / 30.0, times)
    turns = [degrees_between(f[4][:3, :3], dex_frame(f[3], side)) for f in frames if f is not None]
    summary = {
        "records": str(args.records),
        "frames": len(frames),
        "frames_with_the_hand": len(turns),
        "side": side,
        "wrist_frame_vs_dex_svd_deg": {
            "median": float(np.median(turns)),
            "p90": float(np.percentile(turns, 90)),
            "max": float(np.max(turns)),
        },
        "runs": [],
    }
    for robot in args.robots:
        runs = []
        for mode in MODES:
            result, q, names, limits = retarget(robot, mode, side, frames)
            summary["runs"].append(result)
            runs.append((mode, q, names, limits))
            # The same joints in dex-retargeting's own wrist frame, for comparison.
            summary["runs"].append(retarget(robot, mode, side, frames, frame="dex")[0])
        plot(robot, runs, times, args.out / f"{robot}_joints.png")
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    w = summary["wrist_frame_vs_dex_svd_deg"]
    print(
        f"{summary['frames_with_the_hand']} of {summary['frames']} frames with a {side} hand; "
        f"wrist_pose vs dex-retargeting's SVD frame from joints 0/5/9: median {w['median']:.1f}, "
        f"90th percentile {w['p90']:.1f}, max {w['max']:.1f} degrees"
    )
    print()
    print(
        "| robot | mode | wrist frame | config | fingertip error, mm (mean / median) | frames within joint limits "
        "(the URDF's / with the optimizer's 1e-3 rad) | robot wrist vs the wrist pose (median) | ms/frame |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for r in summary["runs"]:
        wrist = (
            f"{r['wrist_error_mm_median']:.1f} mm, {r['wrist_error_deg_median']:.1f} deg"
            if r["mode"] == "position"
            else f"(scaling {r['scaling_factor']})"
        )
        print(
            f"| {r['robot']} | {r['mode']} | {r['wrist_frame']} | `{r['config']}` | {r['fingertip_error_mm_mean']:.1f} / "
            f"{r['fingertip_error_mm_median']:.1f} | {100 * r['within_limits_share']:.1f}% / "
            f"{100 * r['within_limits_and_slack_share']:.1f}% | {wrist} | "
            f"{r['ms_per_frame']:.1f} |"
        )


if __name__ == "__main__":
    main()
