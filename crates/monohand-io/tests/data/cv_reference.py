"""The OpenCV reference numbers of crates/monohand-io/tests/calibration_formats.rs.

Writes, with cv2.FileStorage itself, the two OpenCV files of issue 44's fisheye camera
(150 degrees across 1280x720, k = 0.02, -0.005, 0, 0, principal point at the centre):
`opencv_fisheye.yaml` (`distortion_model: fisheye`, 4 coefficients) and
`opencv_fisheye_sample.yml` (the keys of OpenCV's calibration sample, `fisheye_model: 1`),
reads them back with cv2.FileStorage, and prints as Rust arrays:

- cv2.fisheye.projectPoints of points up to 89 degrees off the axis;
- cv2.fisheye.undistortPoints of pixels, as rays;
- cv2.projectPoints of the same points through the ROS plumb_bob and rational cameras of
  `ros_plumb_bob.yaml` and `ros_rational.yaml`.

Run from this folder with opencv-python-headless (5.0.0 made the numbers in the test) and
numpy; OpenCV is not a dependency of monohand:

    python3 -m venv /tmp/cvref && /tmp/cvref/bin/pip install opencv-python-headless numpy
    /tmp/cvref/bin/python cv_reference.py
"""

import math

import cv2
import numpy as np

W, H = 1280, 720
K1, K2 = 0.02, -0.005
T = math.radians(75.0)
F = 640.0 / (T * (1 + K1 * T * T + K2 * T**4))
K = np.array([[F, 0, 639.5], [0, F, 359.5], [0, 0, 1]], dtype=np.float64)
D = np.array([[K1], [K2], [0.0], [0.0]], dtype=np.float64)

POINTS = np.array(
    [
        [100.0, -50.0, 400.0],
        [300.0, 200.0, 100.0],
        [-500.0, 120.0, 60.0],
        [10.0, 5.0, 2000.0],
        [1000.0, -300.0, 17.0],
    ],
    dtype=np.float64,
).reshape(-1, 1, 3)
PIXELS = np.array(
    [[639.5, 359.5], [0.0, 0.0], [1279.0, 719.0], [900.0, 100.0], [320.0, 500.0]],
    dtype=np.float64,
).reshape(-1, 1, 2)

# The ROS cameras (the numbers of ros_plumb_bob.yaml and ros_rational.yaml).
ROS_K = np.array([[612.41, 0, 321.7], [0, 611.93, 243.28], [0, 0, 1]], dtype=np.float64)
ROS_PLUMB_BOB = np.array([-0.412, 0.188, 0.0012, -0.0007, -0.041], dtype=np.float64)
ROS_RATIONAL = np.array(
    [0.318, -0.112, 0.0009, -0.0004, 0.021, 0.674, -0.051, 0.063], dtype=np.float64
)
ROS_POINTS = np.array(
    [[100.0, -50.0, 400.0], [-150.0, 120.0, 300.0], [0.0, 0.0, 500.0]], dtype=np.float64
).reshape(-1, 1, 3)


def write(path, sample):
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", W)
    fs.write("image_height", H)
    if sample:
        fs.write("flags", 0)
        fs.write("fisheye_model", 1)
    else:
        fs.write("distortion_model", "fisheye")
    fs.write("camera_matrix", K)
    fs.write("distortion_coefficients", D)
    fs.release()


def read(path):
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    k = fs.getNode("camera_matrix").mat()
    d = fs.getNode("distortion_coefficients").mat()
    fs.release()
    return k, d


def rust(name, a):
    rows = ", ".join("[" + ", ".join(repr(float(v)) for v in r) + "]" for r in a)
    print(f"const {name}: [[f64; {a.shape[1]}]; {a.shape[0]}] = [{rows}];")


def main():
    write("opencv_fisheye.yaml", sample=False)
    write("opencv_fisheye_sample.yml", sample=True)
    for path in ["opencv_fisheye.yaml", "opencv_fisheye_sample.yml"]:
        k, d = read(path)
        assert np.array_equal(k, K) and np.array_equal(d, D), path
    print(f"// OpenCV {cv2.__version__}")
    rust("POINTS", POINTS.reshape(-1, 3))
    px, _ = cv2.fisheye.projectPoints(POINTS, np.zeros(3), np.zeros(3), K, D)
    rust("FISHEYE_PIXELS", px.reshape(-1, 2))
    rust("PIXELS", PIXELS.reshape(-1, 2))
    und = cv2.fisheye.undistortPoints(PIXELS, K, D).reshape(-1, 2)
    rays = np.hstack([und, np.ones((len(und), 1))])
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    rust("FISHEYE_RAYS", rays)
    rust("ROS_POINTS", ROS_POINTS.reshape(-1, 3))
    for name, d in [("PLUMB_BOB", ROS_PLUMB_BOB), ("RATIONAL", ROS_RATIONAL)]:
        px, _ = cv2.projectPoints(ROS_POINTS, np.zeros(3), np.zeros(3), ROS_K, d)
        rust(f"{name}_PIXELS", px.reshape(-1, 2))


if __name__ == "__main__":
    main()
