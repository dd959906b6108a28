"""The Daft column types of monohand's tables, re-exported by `monohand.daft`: one hand, a
frame's hands, a tracked frame, per-row intrinsics.

Below `monohand.daft` and the corpus job (`monohand._corpus`), which both take them, so that
neither imports the other for them.
"""

from __future__ import annotations

from daft import DataType

_POINTS = DataType.list(DataType.list(DataType.float32()))

#: One hand. The first four fields are those of ``daft-physical-ai``.
HAND_DTYPE = DataType.struct(
    {
        "handedness": DataType.string(),  # "left" | "right"
        "confidence": DataType.float32(),  # detection score
        "kp2d": _POINTS,  # [[x, y], ...] pixels, 21 joints
        "kp3d": _POINTS,  # [[x, y, z], ...] wrist-relative, metres, camera axes; null if unfitted
        "hand_id": DataType.int64(),  # identity over the video's frames
        "side_score": DataType.float32(),  # the network's probability of `handedness`
        "keypoint_confidence": DataType.list(DataType.float32()),  # per joint, [0, 1]
        "kp3d_camera_mm": _POINTS,  # absolute, camera frame, millimetres
        "pose": DataType.struct(
            {
                "translation_mm": DataType.list(DataType.float64()),
                "quaternion_xyzw": DataType.list(DataType.float64()),
                "angles_rad": DataType.list(DataType.float64()),
            }
        ),
        "reprojection_error_px": DataType.float32(),
    }
)

#: One frame -> its hands.
HANDS_DTYPE = DataType.list(HAND_DTYPE)

#: One frame of a tracked video (``frame`` null in the error row of an unreadable video).
FRAME_DTYPE = DataType.struct(
    {
        "frame": DataType.int64(),
        "time_s": DataType.float64(),
        "hands": HANDS_DTYPE,
        "error": DataType.string(),
    }
)

#: Optional per-row intrinsics (pixels; pixel centres at integer coordinates).
INTRINSICS_DTYPE = DataType.struct(
    {
        "fx": DataType.float64(),
        "fy": DataType.float64(),
        "cx": DataType.float64(),
        "cy": DataType.float64(),
        "width": DataType.int64(),
        "height": DataType.int64(),
    }
)
