#!/usr/bin/env python3
"""Reference outputs of MediaPipe's hand/face networks from the LiteRT interpreter.

Writes the small fixture used by `crates/monohand-vision/tests/reference_agreement.rs`:
real image crops (uint8, so the fixture stays small) and the raw network outputs computed by
the independent `ai-edge-litert` runtime. Not needed by CI; run it when the fixture must be
regenerated:

    python3 -m venv /tmp/litert-venv
    /tmp/litert-venv/bin/pip install ai-edge-litert==2.3.0 numpy pillow
    /tmp/litert-venv/bin/python tools/litert_reference.py \
        --models ~/.cache/monohand/models --data ../shared/data \
        --out crates/monohand-vision/tests/fixtures

Inputs are normalised exactly as the Rust test does: x = u8 / 255 for the palm and landmark
models (range [0, 1]) and x = u8 / 127.5 - 1 for the face detector (range [-1, 1]).
It also times each model (1 thread) for the benchmark comparison.
"""
import argparse
import json
import os
import time

import numpy as np
from PIL import Image
from ai_edge_litert.interpreter import Interpreter


def letterbox(img, size):
    """Aspect-preserving resize into a size x size square, zero padding centred."""
    w, h = img.size
    s = size / max(w, h)
    nw, nh = round(w * s), round(h * s)
    canvas = Image.new("RGB", (size, size))
    canvas.paste(img.resize((nw, nh), Image.BILINEAR), ((size - nw) // 2, (size - nh) // 2))
    return np.asarray(canvas, dtype=np.uint8)


def run(model_path, x, repeats=0):
    it = Interpreter(model_path=model_path, num_threads=1)
    it.allocate_tensors()
    it.set_tensor(it.get_input_details()[0]["index"], x[None].astype(np.float32))
    it.invoke()
    outs = [it.get_tensor(d["index"]).copy() for d in it.get_output_details()]
    ms = None
    if repeats:
        t0 = time.perf_counter()
        for _ in range(repeats):
            it.invoke()
        ms = (time.perf_counter() - t0) / repeats * 1e3
    return outs, ms


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--models", required=True)
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--out", required=True)
    ap.add_argument("--time", type=int, default=50, help="timed repeats per model (0: skip)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    m = lambda name: os.path.join(a.models, name)

    hand = Image.open(os.path.join(a.data, "images/pinto/hand.png")).convert("RGB")
    # Palm detector input: the whole webcam frame letterboxed to 192x192.
    palm_in = letterbox(hand, 192)
    # Landmark input: a square crop around the hand, turned so the fingers point up.
    lm_in = np.asarray(hand.crop((20, 70, 340, 390)).rotate(90).resize((224, 224), Image.BILINEAR), dtype=np.uint8)
    face = Image.open(os.path.join(a.data, "images/interwild/image.jpg")).convert("RGB")
    face_in = letterbox(face, 128)

    timings = {}
    np.save(os.path.join(a.out, "palm_input_u8.npy"), palm_in)
    np.save(os.path.join(a.out, "landmark_input_u8.npy"), lm_in)
    np.save(os.path.join(a.out, "face_input_u8.npy"), face_in)

    (reg, score), timings["palm_detection_full"] = run(m("palm_detection_full.tflite"), palm_in / 255.0, a.time)
    np.save(os.path.join(a.out, "palm_full_regressors.npy"), reg[0])
    np.save(os.path.join(a.out, "palm_full_scores.npy"), score[0])
    (_, score), timings["palm_detection_lite"] = run(m("palm_detection_lite.tflite"), palm_in / 255.0, a.time)
    np.save(os.path.join(a.out, "palm_lite_scores.npy"), score[0])

    for variant in ("full", "lite"):
        outs, timings[f"hand_landmark_{variant}"] = run(m(f"hand_landmark_{variant}.tflite"), lm_in / 255.0, a.time)
        # Identity: 21x3 screen landmarks, Identity_1: presence, Identity_2: handedness, Identity_3: world.
        np.save(os.path.join(a.out, f"landmark_{variant}_outputs.npy"),
                np.concatenate([o.reshape(-1) for o in outs]).astype(np.float32))

    (reg, score), timings["face_detection_short_range"] = run(m("face_detection_short_range.tflite"), face_in / 127.5 - 1.0, a.time)
    np.save(os.path.join(a.out, "face_regressors.npy"), reg[0])
    np.save(os.path.join(a.out, "face_scores.npy"), score[0])

    with open(os.path.join(a.out, "litert_reference.json"), "w") as f:
        json.dump({
            "generator": "tools/litert_reference.py",
            "runtime": "ai-edge-litert",
            "note": "palm/landmark inputs are u8/255, face input is u8/127.5-1; landmark_*_outputs = "
                    "63 screen coords, presence, handedness, 63 world coords",
            "litert_ms_per_inference_1_thread": {k: round(v, 2) for k, v in timings.items() if v},
        }, f, indent=2)
    print(json.dumps(timings, indent=2))


if __name__ == "__main__":
    main()
