#!/usr/bin/env python3
"""Writes the benchmark video: a real photo seen by a moving virtual camera.

The motion is the pipeline tests' (crates/monohand-cli/tests/run_pipeline.rs, `motion(t)`):
a similarity about the image centre c, p' = s R(theta) (p - c) + c + d, with s = 1 + 0.25 t,
theta = 25 deg t, d = (-40 t, 30 t). Here t goes 0 -> 1 -> 0 over the frames (there and back),
so the hand stays in view for any length. Frames are warped with OpenCV (bilinear, black
border) and encoded losslessly in RGB (FFV1, gbrp, in Matroska), so every decoder (ffmpeg's
rgb24 output for monohand, OpenCV's VideoCapture for MediaPipe) reads identical pixels.
FFV1 is written as archivists write it, version 3 with 4 slices (`-level 3 -slices 4`), so
that a decoder can use more than one core (FFmpeg's FFV1 decoder has slice threads only);
`--codec ffv1-1slice` writes the single-slice file of the earlier measurements (the same
pixels; its decoding takes one core, 7.6-8.7 ms per frame on the benchmark machines).
`--codec h264` writes H.264 instead (libx264, CRF 18, yuv420p), as cameras and phones do:
about 1.6 ms per 640x480 frame to decode, so the tools' own speed shows more than the
decoder's (the pixels then differ by the two decoders' YUV-to-RGB conversions).
"""
import argparse
import math
import subprocess

import cv2
import numpy as np

# ffmpeg's encoding arguments and a description, per --codec.
CODECS = {
    "ffv1": (["-c:v", "ffv1", "-level", "3", "-slices", "4", "-pix_fmt", "gbrp"],
             "FFV1 version 3, 4 slices, lossless RGB"),
    "ffv1-1slice": (["-c:v", "ffv1", "-pix_fmt", "gbrp"], "FFV1, one slice, lossless RGB"),
    "h264": (["-c:v", "libx264", "-crf", "18", "-pix_fmt", "yuv420p"], "H.264 CRF 18, yuv420p"),
}


def motion_matrix(t, c):
    s = 1.0 + 0.25 * t
    th = math.radians(25.0 * t)
    d = (-40.0 * t, 30.0 * t)
    a = s * math.cos(th)
    b = s * math.sin(th)
    # p' = A (p - c) + c + d,  A = s [[cos, -sin], [sin, cos]]
    return np.array(
        [
            [a, -b, c[0] + d[0] - (a * c[0] - b * c[1])],
            [b, a, c[1] + d[1] - (b * c[0] + a * c[1])],
        ]
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("photo")
    ap.add_argument("out", help="output video (.mkv)")
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--fps", type=int, default=30)
    ap.add_argument("--codec", choices=list(CODECS), default="ffv1")
    ap.add_argument("--size", help="WxH: ffmpeg scales the frames to this size (bicubic) as it encodes")
    a = ap.parse_args()
    img = cv2.imread(a.photo, cv2.IMREAD_COLOR)
    if img is None:
        raise SystemExit(f"cannot read {a.photo}")
    h, w = img.shape[:2]
    c = ((w - 1) / 2.0, (h - 1) / 2.0)
    n = a.frames
    half = max(1, (n - 1) / 2.0)
    enc = subprocess.Popen(
        ["ffmpeg", "-v", "error", "-y", "-f", "rawvideo", "-pix_fmt", "bgr24",
         "-s", f"{w}x{h}", "-r", str(a.fps), "-i", "-",
         *(["-vf", "scale=%s:%s:flags=bicubic" % tuple(a.size.split("x"))] if a.size else []),
         *CODECS[a.codec][0],
         a.out],
        stdin=subprocess.PIPE,
    )
    for i in range(n):
        t = 1.0 - abs(1.0 - i / half)  # 0 -> 1 -> 0
        m = motion_matrix(t, c)
        frame = cv2.warpAffine(img, m, (w, h), flags=cv2.INTER_LINEAR,
                               borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        enc.stdin.write(frame.tobytes())
    enc.stdin.close()
    if enc.wait() != 0:
        raise SystemExit("ffmpeg failed to encode the video")
    print(f"{a.out}: {n} frames {a.size or f'{w}x{h}'}, {CODECS[a.codec][1]}")


if __name__ == "__main__":
    main()
