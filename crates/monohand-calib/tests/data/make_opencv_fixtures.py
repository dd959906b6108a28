"""Makes the OpenCV fixtures of monohand-calib's real-data tests.

Run with a Python that has opencv-python(-headless) and numpy, from anywhere:

    python make_opencv_fixtures.py /path/to/shared/data/calibration/opencv_stereo_chessboard

It reads OpenCV's 13 stereo pairs (left01..left14.jpg, right01..right14.jpg, no pair 10),
finds the 9x6 inner corners with cv2.findChessboardCorners + cv2.cornerSubPix((11,11),
(-1,-1), 30 iterations / 0.001) and writes, beside this script:

* opencv_corners.json: per camera, per image, the corners in OpenCV's own order (or null
  where OpenCV found no board);
* opencv_reference.json: OpenCV's cv2.calibrateCamera(Extended) per camera (default
  flags, 5 coefficients, 25 mm squares; with its standard deviations of the intrinsics and
  each view's RMS) and cv2.stereoCalibrate on the pairs both cameras saw,
  once with CALIB_FIX_INTRINSIC (from the per-camera results) and once with flags 0
  (intrinsics refined jointly): R as a rotation vector, T in mm, rms.
"""

import json
import os
import sys

import cv2
import numpy as np

COLS, ROWS, SQUARE_MM = 9, 6, 25.0
NUMBERS = [1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14]
HERE = os.path.dirname(os.path.abspath(__file__))


def find(path):
    img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    if img is None:
        sys.exit(f"cannot read {path}")
    ok, c = cv2.findChessboardCorners(img, (COLS, ROWS))
    if not ok:
        return img.shape, None
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
    c = cv2.cornerSubPix(img, c, (11, 11), (-1, -1), crit)
    return img.shape, c.reshape(-1, 2)


def calib(obj, pts, size):
    out = cv2.calibrateCameraExtended(
        [obj] * len(pts), [p.reshape(-1, 1, 2).astype(np.float32) for p in pts], size, None, None
    )
    rms, k, d, _rvecs, _tvecs, std_intr, _std_extr, per_view = out
    return rms, k, d.ravel(), std_intr.ravel()[:9], per_view.ravel()


def cam_json(rms, k, d, std=None, per_view=None):
    out = {
        "fx": k[0, 0], "fy": k[1, 1], "cx": k[0, 2], "cy": k[1, 2],
        "dist": [float(v) for v in d],
    }
    if rms is not None:
        out["rms"] = rms
    if std is not None:
        # One standard deviation of fx fy cx cy k1 k2 p1 p2 k3 (stdDeviationsIntrinsics).
        out["std"] = [float(v) for v in std]
    if per_view is not None:
        out["per_view_rms"] = [float(v) for v in per_view]
    return out


def stereo_json(rms, k1, d1, k2, d2, r, t):
    rvec, _ = cv2.Rodrigues(r)
    return {
        "rms": rms,
        "rvec": [float(v) for v in rvec.ravel()],
        "t_mm": [float(v) for v in t.ravel()],
        "left": cam_json(None, k1, d1.ravel()),
        "right": cam_json(None, k2, d2.ravel()),
    }


def main():
    src = sys.argv[1]
    obj = np.zeros((ROWS * COLS, 3), np.float32)
    obj[:, :2] = np.mgrid[0:COLS, 0:ROWS].T.reshape(-1, 2) * SQUARE_MM
    corners = {"cols": COLS, "rows": ROWS, "square_mm": SQUARE_MM}
    found = {}
    for side in ("left", "right"):
        views = []
        for n in NUMBERS:
            name = f"{side}{n:02d}.jpg"
            shape, c = find(os.path.join(src, name))
            corners["width"], corners["height"] = shape[1], shape[0]
            views.append({"name": name, "corners": None if c is None else
                          [[round(float(x), 4), round(float(y), 4)] for x, y in c]})
            found[(side, n)] = None if c is None else np.array(views[-1]["corners"], np.float32)
        corners[side] = views
    size = (corners["width"], corners["height"])
    ref = {"opencv_version": cv2.__version__, "square_mm": SQUARE_MM}
    per = {}
    for side in ("left", "right"):
        pts = [found[(side, n)] for n in NUMBERS if found[(side, n)] is not None]
        rms, k, d, std, per_view = calib(obj, pts, size)
        per[side] = (k, d)
        ref[side] = cam_json(rms, k, d, std, per_view)
    both = [n for n in NUMBERS if found[("left", n)] is not None and found[("right", n)] is not None]
    lp = [found[("left", n)].reshape(-1, 1, 2) for n in both]
    rp = [found[("right", n)].reshape(-1, 1, 2) for n in both]
    objs = [obj] * len(both)
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-6)
    for key, flags in (("stereo_fix_intrinsic", cv2.CALIB_FIX_INTRINSIC), ("stereo_free", 0)):
        k1, d1 = per["left"][0].copy(), per["left"][1].copy()
        k2, d2 = per["right"][0].copy(), per["right"][1].copy()
        out = cv2.stereoCalibrate(objs, lp, rp, k1, d1, k2, d2, size, flags=flags, criteria=crit)
        rms, k1, d1, k2, d2, r, t = out[:7]
        ref[key] = stereo_json(rms, k1, d1, k2, d2, r, t)
    ref["stereo_pairs"] = len(both)
    with open(os.path.join(HERE, "opencv_corners.json"), "w") as f:
        json.dump(corners, f, separators=(",", ":"))
        f.write("\n")
    with open(os.path.join(HERE, "opencv_reference.json"), "w") as f:
        json.dump(ref, f, indent=1, default=float)
        f.write("\n")
    print(json.dumps(ref, indent=1, default=float))


if __name__ == "__main__":
    main()
