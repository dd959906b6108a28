#!/usr/bin/env python3
"""MediaPipe's own 3D on the hand-graph-cnn development frames: the reference of issue 10's targets.

Runs MediaPipe 0.10.14's Python hand pipeline (the legacy `solutions.hands`, full landmark
network, `min_detection_confidence=0.5`) over the 292 dev crops in order, and scores its
"world" landmarks (metric, root-relative: no position) against the labels the way
`monohand eval` scores its rows: wrist-relative, centroid-aligned and Procrustes-aligned
(PA-MPJPE, with scale) mean joint errors in mm, over the frames with a hand.

Two modes:
  * video: `static_image_mode=False`, MediaPipe's tracking (each crop from the last frame's
    landmarks, the palm detector only when the hand is lost): what a user of MediaPipe on a
    video gets;
  * image: `static_image_mode=True`, the palm detector on every frame.

    python3 bench/mediapipe_reference/mediapipe_world.py ../shared/data/hand_graph_cnn_dev

Needs the mediapipe==0.10.14 virtual environment of bench/pipeline (bench/pipeline/run.sh
makes it): `bench/pipeline/.venv/bin/python bench/mediapipe_reference/mediapipe_world.py ...`.
The numbers are in docs/accuracy.md.
"""
import json
import os
import sys

import cv2
import mediapipe as mp
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "accuracy_floor"))
from floor import pa_errors  # noqa: E402  (the same Procrustes alignment as the floor)


def run(dataset, frames, static):
    rows = []
    with mp.solutions.hands.Hands(
        static_image_mode=static,
        max_num_hands=1,
        model_complexity=1,
        min_detection_confidence=0.5,
        min_tracking_confidence=0.5,
    ) as hands:
        for f in frames:
            bgr = cv2.imread(os.path.join(dataset, f["image"]))
            res = hands.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
            if not res.multi_hand_world_landmarks:
                continue
            w = res.multi_hand_world_landmarks[0].landmark
            p = np.array([[l.x, l.y, l.z] for l in w]) * 1000.0
            g = np.array(f["joints_3d_mm"])
            rows.append(
                (
                    np.linalg.norm((p - p[0]) - (g - g[0]), axis=1).mean(),
                    np.linalg.norm((p - p.mean(0)) - (g - g.mean(0)), axis=1).mean(),
                    pa_errors(p, g).mean(),
                )
            )
    return rows


def main():
    dataset = sys.argv[1]
    labels = json.load(open(os.path.join(dataset, "labels.json")))
    frames = labels["frames"]
    print("| MediaPipe 0.10.14, world landmarks | frames with a hand | wrist-relative | centroid-aligned | PA-MPJPE |")
    print("|---|---|---|---|---|")
    for name, static in (("video mode (tracking)", False), ("image mode (detector every frame)", True)):
        rows = run(dataset, frames, static)
        m = np.mean(rows, axis=0)
        print(f"| {name} | {len(rows)} / {len(frames)} | {m[0]:.2f} | {m[1]:.2f} | {m[2]:.2f} |")


if __name__ == "__main__":
    main()
