"""Streams a video's tracked 3D hands into the rerun viewer: the image with the 2D
keypoints, the camera, and each hand's skeleton in millimetres in the camera's frame.

    pip install rerun-sdk==0.41.0
    python examples/python/rerun_hands.py clip.mp4 [--camera cam.json] [--save hands.rrd]

Without --save it spawns the viewer.
"""

from __future__ import annotations

import argparse

import numpy as np
import rerun as rr

import monohand

# Bones as joint index pairs: each finger chains from the wrist (MediaPipe's order).
BONES = [(0, 1 + 4 * f) for f in range(5)] + [
    (1 + 4 * f + k, 2 + 4 * f + k) for f in range(5) for k in range(3)
]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("video")
    ap.add_argument("--camera", help="calibration file (default: a generic camera)")
    ap.add_argument("--save", help="write a .rrd file instead of spawning the viewer")
    args = ap.parse_args()

    rr.init("monohand", spawn=args.save is None)
    if args.save:
        rr.save(args.save)
    rr.log("world", rr.ViewCoordinates.RDF, static=True)  # x right, y down, z forward

    video = monohand.read_video(args.video)
    w, h = video.size
    cam = monohand.Camera.load(args.camera) if args.camera else monohand.Camera.generic(w, h)
    rr.log("world/camera", rr.Pinhole(image_from_camera=cam.k, width=w, height=h), static=True)

    with video, monohand.Session([cam], hands=2) as session:
        for frame in video:
            rr.set_time("time", duration=frame.time_s)
            rr.log("world/camera/image", rr.Image(frame.image))
            rr.log("world/hands", rr.Clear(recursive=True))
            for hand in session.process(frame.image, frame.time_s):
                kp = hand.keypoints_2d
                rr.log(f"world/camera/image/hand_{hand.id}", rr.Points2D(kp[:, :2], radii=3.0))
                j = hand.joints_3d_mm
                if j is None:
                    continue
                path = f"world/hands/{hand.side}_{hand.id}"
                rr.log(f"{path}/joints", rr.Points3D(j, radii=4.0))
                rr.log(f"{path}/bones", rr.LineStrips3D([j[[a, b]] for a, b in BONES], radii=2.0))
                rr.log(f"{path}/wrist_mm", rr.TextLog(f"{hand.side} {hand.id}: wrist {np.round(j[0])} mm"))


if __name__ == "__main__":
    main()
