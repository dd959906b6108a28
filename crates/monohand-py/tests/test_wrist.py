"""A hand as robot-hand retargeting reads it (`Hand.wrist_pose`, `Hand.joints_in_wrist_frame`):
MANO's wrist frame as dex-retargeting builds it, in metres, on the dev frames' real left hand
lifted from its 2D, on its mirror image as a right hand, and the same numbers from
`monohand lift --wrist-pose`."""

from __future__ import annotations

import numpy as np
import pytest

import monohand
from conftest import dev_keypoints, read_jsonl, run_cli, write_lift_input

#: dex-retargeting's OPERATOR2MANO_RIGHT and OPERATOR2MANO_LEFT (its MediaPipe example).
OPERATOR2MANO = {
    "right": np.array([[0, 0, -1], [-1, 0, 0], [0, 1, 0]], dtype=float),
    "left": np.array([[0, 0, -1], [1, 0, 0], [0, -1, 0]], dtype=float),
}


def dex_frame(joints: np.ndarray, side: str) -> np.ndarray:
    """dex-retargeting's wrist frame from joints 0, 5 and 9, re-derived: x from the middle MCP
    to the wrist square to the points' plane, y its normal (SVD), z = x cross y towards the
    index MCP; the axes are the columns of F @ OPERATOR2MANO."""
    p = joints[[0, 5, 9]]
    x_vector = p[0] - p[2]
    _, _, vt = np.linalg.svd(p - p.mean(axis=0))
    normal = vt[2]
    x = x_vector - (x_vector @ normal) * normal
    x /= np.linalg.norm(x)
    z = np.cross(x, normal)
    if z @ (p[1] - p[2]) < 0:
        normal, z = -normal, -z
    return np.stack([x, normal, z], axis=1) @ OPERATOR2MANO[side]


def degrees(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(a.T @ b) - 1) / 2, -1, 1))))


def test_the_wrist_pose_and_the_joints_in_its_frame(tmp_path):
    cam, kps = dev_keypoints()
    hands = [monohand.lift(kp, cam, side="left") for kp in kps]
    turns = []
    for h in hands:
        m = h.wrist_pose()
        assert m.shape == (4, 4) and m.dtype == np.float64
        r, t = m[:3, :3], m[:3, 3]
        assert np.array_equal(m[3], [0, 0, 0, 1])
        # At the wrist joint, in metres; a rotation.
        assert np.allclose(t * 1000.0, h.joints_3d_mm[0], atol=1e-9)
        assert np.allclose(r.T @ r, np.eye(3), atol=1e-12) and abs(np.linalg.det(r) - 1) < 1e-12
        # The frame dex-retargeting builds from joints 0, 5 and 9 (the model's own palm turns
        # 1.8 degrees from its three joints; the fit's joints, moved towards the pixels after
        # the fit, tilt more on the frames the model fits worst).
        turns.append(degrees(r, dex_frame(h.joints_3d_mm, "left")))
        # The joints in that frame: metres, the wrist at the origin, the fingers along +z.
        local = h.joints_in_wrist_frame()
        assert local.shape == (21, 3) and local.dtype == np.float64
        assert np.array_equal(local[0], [0, 0, 0])
        assert np.allclose(local, (h.joints_3d_mm / 1000.0 - t) @ r, atol=1e-12)
        assert local[9, 2] > 0.08 and np.hypot(*local[9, :2]) < 0.01
        assert np.array_equal(h.joints_in_wrist_frame("mano"), local)
        # On a left hand +y points to the little finger, so the thumb is on -y.
        assert local[2, 1] < -0.02 and local[4, 1] < 0 < local[17, 1]
        assert "wrist_pose" not in h.to_dict()
    # 1.2-4.1 degrees, and 20.3 on the frame the model fits worst (10.7 px; test_xr.py's
    # palm tilts as much there).
    assert np.median(turns) < 5.0 and max(turns) < 25.0, turns

    for bad in ["opengl", "MANO", ""]:
        with pytest.raises(ValueError, match="unknown wrist frame convention"):
            hands[0].joints_in_wrist_frame(bad)

    # `monohand lift --wrist-pose` writes the same matrices.
    src, cam_path = write_lift_input(tmp_path, cam, kps)
    out = tmp_path / "wrist.jsonl"
    run_cli("lift", "--jsonl", str(src), "--camera", str(cam_path), "-o", str(out), "--wrist-pose")
    for h, rec in zip(hands, read_jsonl(out)):
        w = rec["hands"][0]["wrist_pose"]
        assert w["convention"] == "mano"
        assert np.array_equal(np.array(w["matrix_m"]), h.wrist_pose())


def test_a_right_hand_is_the_left_ones_mirror_in_the_wrist_frame():
    # The same keypoints mirrored about the principal point's column, lifted as a right hand:
    # its 3D is the left's mirrored (x -> -x), and in the wrist frame the right's joints are
    # the left's with y turned back.
    cam, kps = dev_keypoints(step=120)
    for kp in kps:
        mirrored = kp.copy()
        mirrored[:, 0] = 2.0 * cam.cx - kp[:, 0]
        left = monohand.lift(kp, cam, side="left")
        right = monohand.lift(mirrored, cam, side="right")
        flip = np.array([-1.0, 1.0, 1.0])
        assert np.abs(right.joints_3d_mm - left.joints_3d_mm * flip).max() < 0.5
        a, b = left.joints_in_wrist_frame(), right.joints_in_wrist_frame()
        assert np.abs(b - a * np.array([1.0, -1.0, 1.0])).max() < 0.5e-3
        assert a[4, 1] < 0 < b[4, 1]

