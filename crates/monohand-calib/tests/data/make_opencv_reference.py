"""Makes opencv_stereo_chessboard_corners.txt: OpenCV's corners on the 26 sample photos.

Run with a Python that has opencv-python (here 5.0.0, /work/cvref/bin/python):
    python make_opencv_reference.py /path/to/shared/data/calibration/opencv_stereo_chessboard

For each photo: cv2.findChessboardCorners(img, (9, 6)) with OpenCV's default flags
(adaptive threshold + normalize image), then cv2.cornerSubPix(zeroZone (-1, -1),
criteria 30 iterations / eps 0.001) twice from the same start: winSize (11, 11) (OpenCV's
tutorials' choice; winSize is the HALF window, so a 23x23 window) and winSize (5, 5)
(an 11x11 window). The corners are written in OpenCV's own order (which may differ from
monohand's: the tests match them as sets).
"""
import sys
from pathlib import Path

import cv2

folder = Path(sys.argv[1])
names = [f"{side}{i:02d}.jpg" for side in ("left", "right") for i in range(1, 15) if i != 10]
criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
out = [
    "# OpenCV's chessboard corners on the 26 photos of calibration/opencv_stereo_chessboard",
    f"# (9x6 inner corners), made by make_opencv_reference.py with opencv-python {cv2.__version__}:",
    "# findChessboardCorners (default flags) + cornerSubPix(winSize W, zeroZone (-1,-1),",
    "# 30 iterations / eps 0.001), W = (11,11) (a 23x23 window) and W = (5,5) (11x11). One line",
    "# per photo and window: the photo's name, the half window (11 or 5), then 54 'x y' pairs",
    "# in OpenCV's order (pixel centres at integer coordinates).",
]
for name in names:
    img = cv2.imread(str(folder / name), cv2.IMREAD_GRAYSCALE)
    ok, corners = cv2.findChessboardCorners(img, (9, 6))
    if not ok:
        raise SystemExit(f"{name}: OpenCV found no board")
    for half in (11, 5):
        refined = cv2.cornerSubPix(img, corners.copy(), (half, half), (-1, -1), criteria)
        pts = " ".join(f"{x:.4f} {y:.4f}" for x, y in refined.reshape(-1, 2))
        out.append(f"{name} {half} {pts}")
(Path(__file__).parent / "opencv_stereo_chessboard_corners.txt").write_text("\n".join(out) + "\n")
print(f"{len(names)} photos written")
