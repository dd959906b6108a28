"""Makes opencv_stereo_chessboard_corners.txt: OpenCV's corners on the 26 sample photos.

Run with a Python that has opencv-python (here 5.0.0, /work/cvref/bin/python):
    python make_opencv_reference.py /path/to/shared/data/calibration/opencv_stereo_chessboard

For each photo: cv2.findChessboardCorners(img, (9, 6)) with OpenCV's default flags
(adaptive threshold + normalize image), then cv2.cornerSubPix(winSize (11, 11),
zeroZone (-1, -1), criteria 30 iterations / eps 0.001). The corners are written in
OpenCV's own order (which may differ from monohand's: the tests match them as sets).
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
    "# findChessboardCorners (default flags) + cornerSubPix(winSize (11,11), zeroZone (-1,-1),",
    "# 30 iterations / eps 0.001). One line per photo: its name, then 54 'x y' pairs in",
    "# OpenCV's order (pixel centres at integer coordinates).",
]
for name in names:
    img = cv2.imread(str(folder / name), cv2.IMREAD_GRAYSCALE)
    ok, corners = cv2.findChessboardCorners(img, (9, 6))
    if not ok:
        raise SystemExit(f"{name}: OpenCV found no board")
    corners = cv2.cornerSubPix(img, corners, (11, 11), (-1, -1), criteria)
    pts = " ".join(f"{x:.4f} {y:.4f}" for x, y in corners.reshape(-1, 2))
    out.append(f"{name} {pts}")
(Path(__file__).parent / "opencv_stereo_chessboard_corners.txt").write_text("\n".join(out) + "\n")
print(f"{len(names)} photos written")
