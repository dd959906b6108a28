"""A hand as OpenXR's 26 hand joints (`Hand.xr_joints`, `Hand.xr_radii`), lifted from a real
hand's 2D (the hand-graph-cnn dev frames' labels seen by their camera), and the same numbers
from `monohand lift --xr-joints`."""

from __future__ import annotations

import numpy as np

import monohand
from conftest import dev_keypoints, read_jsonl, rotate, run_cli, write_lift_input


def test_xr_joints_are_26_poses_along_the_bones(tmp_path):
    cam, kps = dev_keypoints()
    hands = [monohand.lift(kp, cam, side="left") for kp in kps]

    names = monohand.XR_JOINT_NAMES
    assert len(names) == 26 and names[:2] == ["palm", "wrist"] and names[25] == "little_tip"
    prox, inter = names.index("index_proximal"), names.index("index_intermediate")
    for h in hands:
        xr, radii = h.xr_joints, h.xr_radii
        assert xr.shape == (26, 7) and xr.dtype == np.float64 and radii.shape == (26,)
        assert np.allclose(np.linalg.norm(xr[:, 3:], axis=1), 1.0)
        j = h.joints_3d_mm
        # The joints the model has are its own: the wrist, the index MCP (proximal)...
        assert np.array_equal(xr[1, :3], j[0]) and np.array_equal(xr[prox, :3], j[5])
        # ... whose -Z runs down the proximal phalanx to the intermediate joint (the PIP).
        forward = rotate(xr[prox, 3:], np.array([0.0, 0.0, -1.0]))
        bone = xr[inter, :3] - xr[prox, :3]
        cos = forward @ bone / np.linalg.norm(bone)
        assert cos > 1.0 - 1e-12, cos
        # The palm's +Y leaves by the back of the hand: the model's (the hand frame's -z)...
        up = rotate(xr[0, 3:], np.array([0.0, 1.0, 0.0]))
        assert up @ rotate(h.pose.quaternion_xyzw, np.array([0.0, 0.0, -1.0])) > 0.99
        # ... and a left hand's back from its joints, which the fusion with the pixels
        # tilts a little (up to 20 degrees here, on the frame the model fits worst: 10.7 px).
        back = np.cross(j[5] - j[0], j[9] - j[0])
        assert up @ back / np.linalg.norm(back) > 0.9
        # Radii of an adult hand, mm: the fingertips 4-8, the palm and wrist 10-25.
        assert (radii[[5, 10, 15, 20, 25]] < 8.0).all() and (radii > 4.0).all()
        assert 10.0 < radii[0] < 25.0 and 10.0 < radii[1] < 25.0
        # Not in the records unless asked for.
        assert "xr_joints" not in h.to_dict()

    # `monohand lift --xr-joints` writes the same joints.
    src, cam_path = write_lift_input(tmp_path, cam, kps)
    out = tmp_path / "xr.jsonl"
    run_cli("lift", "--jsonl", str(src), "--camera", str(cam_path), "-o", str(out), "--xr-joints")
    for h, rec in zip(hands, read_jsonl(out)):
        entries = rec["hands"][0]["xr_joints"]
        assert [e["name"] for e in entries] == names
        cli = np.array([e["position_mm"] + e["orientation_xyzw"] for e in entries])
        assert np.array_equal(cli, h.xr_joints)
        assert np.array_equal(np.array([e["radius_mm"] for e in entries]), h.xr_radii)
