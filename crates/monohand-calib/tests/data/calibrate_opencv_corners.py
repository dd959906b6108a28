"""OpenCV's calibration of OpenCV's own corners, for both subpixel windows.

Reads opencv_stereo_chessboard_corners.txt (OpenCV's findChessboardCorners + cornerSubPix
with winSize (11, 11) and (5, 5) on the 26 shared photos) and prints, per window,
cv2.calibrateCamera per camera (default flags: k1 k2 p1 p2 k3) and cv2.stereoCalibrate
(flags 0: the intrinsics refined too), squares of 25 mm. Run with opencv-python
(5.0.0 here: /work/cvref/bin/python); the numbers are copied into tests/end_to_end.rs.
"""
import numpy as np
import cv2

rows = {}
for line in open("opencv_stereo_chessboard_corners.txt"):
    if line.startswith("#") or not line.strip():
        continue
    p = line.split()
    rows[(p[0], int(p[1]))] = np.array(list(map(float, p[2:])), np.float32).reshape(-1, 1, 2)
obj = np.zeros((54, 3), np.float32)
obj[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2) * 25
for w in (11, 5):
    cams = {}
    for cam in ("left", "right"):
        names = sorted(n for (n, ww) in rows if ww == w and n.startswith(cam))
        ip = [rows[(n, w)] for n in names]
        rms, K, d, _, _ = cv2.calibrateCamera([obj] * len(ip), ip, (640, 480), None, None)
        cams[cam] = (ip, K, d)
        print(f"window {w} {cam}: fx {K[0,0]:.3f} fy {K[1,1]:.3f} cx {K[0,2]:.3f} cy {K[1,2]:.3f} rms {rms:.4f}")
    (il, Kl, dl), (ir, Kr, dr) = cams["left"], cams["right"]
    rms, *_, R, T, _, _ = cv2.stereoCalibrate([obj] * len(il), il, ir, Kl, dl, Kr, dr, (640, 480), flags=0)
    rv = cv2.Rodrigues(R)[0].ravel()
    print(f"window {w} stereo: rvec {rv.tolist()} T {T.ravel().tolist()} rms {rms:.4f}")
