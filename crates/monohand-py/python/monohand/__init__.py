"""monohand: absolute 3D hand pose, in millimetres in your camera's frame, from ordinary RGB
video, in real time on a CPU.

>>> import monohand
>>> cam = monohand.Camera.generic(640, 480)            # or Camera(fx, fy, cx, cy, w, h), Camera.load(path)
>>> with monohand.Session([cam], hands=2) as s:        # doctest: +SKIP
...     for frame in monohand.read_video("clip.mp4"):
...         for hand in s.process(frame.image, frame.time_s):
...             print(hand.id, hand.side, hand.joints_3d_mm[0])   # the wrist, mm

- `Session`: frames in (one ``(H, W, 3)`` uint8 RGB array per camera), tracked hands out.
- `Lifter` / `lift`: 2D keypoints made elsewhere in, absolute 3D out.
- `HandSize`: a person's hand measured once (``monohand run --save-hand``) or by ruler, for
  ``Session(hand=...)``: the absolute depth scales with it.
- `read_video`: the frames of a video file, decoded by ffmpeg.
- `calibrate`: a camera's (or a rig's) calibration from photos or a video of a chessboard.
- `lerobot_dataset`: one LeRobot v3 dataset of the episodes `Session.track(lerobot=...)` wrote.
- `track_video`: a whole video to a table, one row per frame per hand.
- `monohand.daft`: the same over a corpus of videos with Daft (native or on Ray).

The networks (MediaPipe's hand detector and landmark model) and the 3D fit run in Rust with
the GIL released. Their weights are fetched with pip from MediaPipe's wheel on first use and
cached (see `fetch_models`).
"""

from __future__ import annotations

from typing import Any, Iterator, Optional

from ._monohand import (
    JOINT_NAMES,
    NUM_JOINTS,
    XR_JOINT_NAMES,
    Camera,
    Frame,
    FrameStream,
    Hand,
    HandSize,
    Lifter,
    Models,
    MonohandError,
    Pose,
    Session,
    TrackedFrame,
    VideoReader,
    __version__,
    calibrate,
    lerobot_dataset,
    fetch_models,
)

__all__ = [
    "JOINT_NAMES",
    "NUM_JOINTS",
    "XR_JOINT_NAMES",
    "Camera",
    "Frame",
    "FrameStream",
    "Hand",
    "HandSize",
    "Lifter",
    "Models",
    "MonohandError",
    "Pose",
    "Session",
    "TrackedFrame",
    "VideoReader",
    "__version__",
    "calibrate",
    "lerobot_dataset",
    "fetch_models",
    "lift",
    "read_video",
    "row_schema",
    "track_video",
    "video_rows",
]


def read_video(path: str) -> VideoReader:
    """The frames of a video (any file ffmpeg reads), in order: each has ``index``,
    ``time_s`` and ``image``, an ``(H, W, 3)`` uint8 RGB array."""
    return VideoReader(str(path))


def lift(keypoints_2d: Any, camera: Camera, side: str = "right", hand_scale: float = 1.0) -> Hand:
    """Lifts one hand's 2D keypoints, ``(21, 2)`` or ``(21, 3)`` with confidence, in
    MediaPipe's joint order, to absolute 3D in ``camera``'s frame (one frame, no tracking;
    use a `Lifter` for a sequence)."""
    import numpy as np

    return Lifter(camera, tracking=False, hand_scale=hand_scale).lift(
        np.asarray(keypoints_2d, dtype=np.float64), side
    )


def _row(frame: int, time_s: float, hand: Optional[Hand], error: Optional[str]) -> dict:
    """One output row: a frame's hand, or a frame without hands (``hand_id`` null)."""
    row: dict = {"frame": frame, "time_s": time_s, "error": error}
    if hand is None:
        row.update(
            hand_id=None,
            side=None,
            side_score=None,
            score=None,
            keypoints_2d=None,
            joints_3d_mm=None,
            pose_translation_mm=None,
            pose_quaternion_xyzw=None,
            pose_angles_rad=None,
            reprojection_error_px=None,
        )
        return row
    pose = hand.pose
    j3 = hand.joints_3d_mm
    row.update(
        hand_id=hand.id,
        side=hand.side,
        side_score=hand.side_score,
        score=hand.score,
        keypoints_2d=hand.keypoints_2d.tolist(),
        joints_3d_mm=None if j3 is None else j3.tolist(),
        pose_translation_mm=None if pose is None else pose.translation_mm.tolist(),
        pose_quaternion_xyzw=None if pose is None else pose.quaternion_xyzw.tolist(),
        pose_angles_rad=None if pose is None else pose.angles_rad.tolist(),
        reprojection_error_px=hand.reprojection_error_px,
    )
    return row


def video_rows(
    path: str,
    camera: Optional[Camera] = None,
    *,
    hands: int = 2,
    model_dir: Optional[str] = None,
    smoothing: bool = False,
    max_frames: Optional[int] = None,
    empty_frames: bool = True,
    models: Optional[Models] = None,
    mirror_pass: bool = True,
    offline: bool = False,
    precision: str = "auto",
) -> Iterator[dict]:
    """Tracks a whole video and yields plain rows: one per frame per hand, plus (with
    ``empty_frames``) one row with ``hand_id=None`` for each frame without hands, so that
    every frame appears. Raises `MonohandError` if the video cannot be read. The video runs
    through the same engine as ``monohand run`` (`Session.track`); ``offline=True`` is
    ``run --offline`` (each frame refitted with the frames after it too)."""
    with Session(
        camera,
        hands=hands,
        model_dir=model_dir,
        smoothing=smoothing,
        models=models,
        mirror_pass=mirror_pass,
        precision=precision,
    ) as session, session.track(str(path), max_frames=max_frames, offline=offline) as frames:
        for frame in frames:
            found = frame.hands
            if not found and empty_frames:
                yield _row(frame.index, frame.time_s, None, frame.error)
            for hand in found:
                yield _row(frame.index, frame.time_s, hand, frame.error)


def track_video(
    path: str,
    camera: Optional[Camera] = None,
    *,
    hands: int = 2,
    model_dir: Optional[str] = None,
    smoothing: bool = False,
    max_frames: Optional[int] = None,
    output: str = "pandas",
    mirror_pass: bool = True,
    offline: bool = False,
    precision: str = "auto",
) -> Any:
    """Tracks a whole video and returns a table with one row per frame per hand (and one
    row with null hand fields for each frame without hands): a pandas DataFrame
    (``output="pandas"``) or a pyarrow Table (``output="arrow"``).

    Columns: ``frame, time_s, error, hand_id, side, side_score, score, keypoints_2d (21x3),
    joints_3d_mm (21x3), pose_translation_mm, pose_quaternion_xyzw, pose_angles_rad,
    reprojection_error_px``.
    """
    if output not in ("pandas", "arrow"):
        raise ValueError(f"output must be 'pandas' or 'arrow', not {output!r}")
    try:  # before the video is tracked, not after
        import pyarrow as pa

        if output == "pandas":
            import pandas  # noqa: F401
    except ImportError as e:
        raise ImportError(f"track_video needs {e.name}: pip install 'monohand[table]'") from e
    rows = video_rows(
        path,
        camera,
        hands=hands,
        model_dir=model_dir,
        smoothing=smoothing,
        max_frames=max_frames,
        mirror_pass=mirror_pass,
        offline=offline,
        precision=precision,
    )
    table = pa.Table.from_pylist(list(rows), schema=row_schema())
    return table.to_pandas() if output == "pandas" else table


def row_schema() -> Any:
    """The pyarrow schema of `track_video`'s rows."""
    import pyarrow as pa

    points = pa.list_(pa.list_(pa.float64()))
    return pa.schema(
        [
            ("frame", pa.int64()),
            ("time_s", pa.float64()),
            ("error", pa.string()),
            ("hand_id", pa.int64()),
            ("side", pa.string()),
            ("side_score", pa.float64()),
            ("score", pa.float64()),
            ("keypoints_2d", points),
            ("joints_3d_mm", points),
            ("pose_translation_mm", pa.list_(pa.float64())),
            ("pose_quaternion_xyzw", pa.list_(pa.float64())),
            ("pose_angles_rad", pa.list_(pa.float64())),
            ("reprojection_error_px", pa.float64()),
        ]
    )

