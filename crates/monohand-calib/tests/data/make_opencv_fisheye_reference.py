"""Makes opencv_fisheye_reference.json: cv2.fisheye.calibrate on OpenCV's stereo sample.

Run with a throw-away Python that has opencv-python(-headless) and numpy (never a
dependency of the project), from anywhere:

    python make_opencv_fisheye_reference.py

It reads opencv_corners.json beside it (OpenCV's findChessboardCorners + cornerSubPix
corners on the 13 left and 13 right photos, made by make_opencv_fixtures.py: the very
corners tests/fisheye.rs gives monohand's calibration) and writes, per camera,
cv2.fisheye.calibrate with CALIB_RECOMPUTE_EXTRINSIC | CALIB_FIX_SKEW (k1..k4, fx fy cx
cy; 25 mm squares; 200 iterations or a relative change of 1e-12), and, per camera, the
RMS reprojection error recomputed with cv2.fisheye.projectPoints from its poses as
sqrt(sum |e|^2 / N_corners) (monohand's definition) beside OpenCV's own returned value.
Then cv2.fisheye.stereoCalibrate on the pairs both cameras saw, with CALIB_FIX_INTRINSIC
(from the per-camera results): R as a rotation vector, T in mm, rms.
"""

import json
import os

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
# OpenCV 5 keeps the fisheye's flags in cv2 (4.x: cv2.fisheye.CALIB_*).
NS = cv2.fisheye if hasattr(cv2.fisheye, "CALIB_FIX_SKEW") else cv2
FLAGS = NS.CALIB_RECOMPUTE_EXTRINSIC | NS.CALIB_FIX_SKEW
CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)


def main():
    with open(os.path.join(HERE, "opencv_corners.json")) as f:
        corners = json.load(f)
    cols, rows, square = corners["cols"], corners["rows"], corners["square_mm"]
    size = (corners["width"], corners["height"])
    # cv2.fisheye wants (1, N, 3) and (1, N, 2) arrays of float64 (not (N, 1, .)).
    obj = np.zeros((1, rows * cols, 3), np.float64)
    obj[0, :, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square
    ref = {
        "opencv_version": cv2.__version__,
        "flags": "CALIB_RECOMPUTE_EXTRINSIC | CALIB_FIX_SKEW",
        "square_mm": square,
    }
    per = {}
    for side in ("left", "right"):
        names = [v["name"] for v in corners[side] if v["corners"] is not None]
        pts = [np.array(v["corners"], np.float64).reshape(1, -1, 2)
               for v in corners[side] if v["corners"] is not None]
        k, d = np.eye(3), np.zeros((4, 1))
        rms, k, d, rvecs, tvecs = cv2.fisheye.calibrate(
            [obj] * len(pts), pts, size, k, d, flags=FLAGS, criteria=CRITERIA)
        sse, n, per_view = 0.0, 0, []
        for p, rv, tv in zip(pts, rvecs, tvecs):
            proj, _ = cv2.fisheye.projectPoints(obj, rv, tv, k, d)
            e = np.sum((proj.reshape(-1, 2) - p.reshape(-1, 2)) ** 2)
            m = p.shape[1]
            sse, n = sse + e, n + m
            per_view.append(float(np.sqrt(e / m)))
        per[side] = (k, d)
        ref[side] = {
            "views": names,
            "fx": k[0, 0], "fy": k[1, 1], "cx": k[0, 2], "cy": k[1, 2],
            "k": [float(v) for v in d.ravel()],
            "rms": float(np.sqrt(sse / n)),
            "opencv_returned_rms": rms,
            "per_view_rms": per_view,
        }
    lv = {v["name"][4:]: v["corners"] for v in corners["left"] if v["corners"] is not None}
    rv = {v["name"][5:]: v["corners"] for v in corners["right"] if v["corners"] is not None}
    both = sorted(set(lv) & set(rv))
    lp = [np.array(lv[n], np.float64).reshape(1, -1, 2) for n in both]
    rp = [np.array(rv[n], np.float64).reshape(1, -1, 2) for n in both]
    (k1, d1), (k2, d2) = per["left"], per["right"]
    out = cv2.fisheye.stereoCalibrate(
        [obj] * len(both), lp, rp, k1.copy(), d1.copy(), k2.copy(), d2.copy(), size,
        flags=NS.CALIB_FIX_INTRINSIC, criteria=CRITERIA)
    rms, r, t = out[0], out[5], out[6]
    ref["stereo_fix_intrinsic"] = {
        "pairs": len(both),
        "rms": rms,
        "rvec": [float(v) for v in cv2.Rodrigues(r)[0].ravel()],
        "t_mm": [float(v) for v in np.asarray(t).ravel()],
    }
    with open(os.path.join(HERE, "opencv_fisheye_reference.json"), "w") as f:
        json.dump(ref, f, indent=1, default=float)
        f.write("\n")
    print(json.dumps(ref, indent=1, default=float))


if __name__ == "__main__":
    main()
