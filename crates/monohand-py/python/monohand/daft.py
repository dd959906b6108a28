"""monohand on Daft: tracked absolute 3D hands over a corpus of videos, or a column of
images, on Daft's native runner or on Ray.

Per video (the unit of parallelism: a video is tracked in order, each fit starting from the
last, so one video runs on one worker; different videos run side by side):

>>> import daft, monohand.daft as mhd                                    # doctest: +SKIP
>>> df = daft.from_pydict({"path": ["a.mp4", "b.mp4"]})                  # doctest: +SKIP
>>> frames = mhd.track_videos(df, "path")       # one row per frame       # doctest: +SKIP
>>> frames.write_parquet("hands/")                                      # doctest: +SKIP

Each output row has the input's columns and ``frame``, ``time_s``, ``hands`` (a list of
`HAND_DTYPE`) and ``error``. A video that cannot be read gives one row with ``frame`` null
and the reason in ``error``: the job goes on.

`HAND_DTYPE` carries the field names of ``daft-physical-ai``'s ``track_hands`` where they mean
the same thing (``handedness``, ``confidence``, ``kp2d``, ``kp3d``) and explicit fields where
they do not: ``kp3d_camera_mm`` (absolute, in the camera's frame, mm), ``hand_id``,
``side_score``, ``pose`` and ``reprojection_error_px``. ``kp3d`` is the hand-centred 3D
(wrist-relative, metres, camera axes), comparable with WiLoR's.
"""

from __future__ import annotations

import os
from typing import Any, Dict, List, Optional

import daft
from daft import DataType, Expression

import monohand

__all__ = [
    "FRAME_DTYPE",
    "HAND_DTYPE",
    "HANDS_DTYPE",
    "INTRINSICS_DTYPE",
    "HandImages",
    "VideoTracker",
    "hand_struct",
    "track_images",
    "track_videos",
]

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


def hand_struct(hand: monohand.Hand) -> Dict[str, Any]:
    """A `monohand.Hand` as a `HAND_DTYPE` value."""
    kp = hand.keypoints_2d
    j3 = hand.joints_3d_mm
    pose = hand.pose
    return {
        "handedness": hand.side,
        "confidence": hand.score,
        "kp2d": kp[:, :2].tolist(),
        "kp3d": None if j3 is None else ((j3 - j3[0]) / 1000.0).tolist(),
        "hand_id": hand.id,
        "side_score": hand.side_score,
        "keypoint_confidence": kp[:, 2].tolist(),
        "kp3d_camera_mm": None if j3 is None else j3.tolist(),
        "pose": None
        if pose is None
        else {
            "translation_mm": pose.translation_mm.tolist(),
            "quaternion_xyzw": pose.quaternion_xyzw.tolist(),
            "angles_rad": pose.angles_rad.tolist(),
        },
        "reprojection_error_px": hand.reprojection_error_px,
    }


def _camera(intrinsics: Optional[Dict[str, Any]]) -> Optional[monohand.Camera]:
    if intrinsics is None:
        return None
    return monohand.Camera(
        float(intrinsics["fx"]),
        float(intrinsics["fy"]),
        float(intrinsics["cx"]),
        float(intrinsics["cy"]),
        int(intrinsics["width"]),
        int(intrinsics["height"]),
    )


class _VideoTracker:
    """Tracks whole videos. The networks are loaded once per instance (`monohand.Models`)
    and shared by the session of each video it tracks."""

    def __init__(
        self,
        hands: int = 2,
        model_dir: Optional[str] = None,
        smoothing: bool = False,
        offline: Optional[bool] = None,
    ):
        if offline is None:  # corpora are offline by nature, unless the causal filter is asked
            offline = not smoothing
        if smoothing and offline:
            raise ValueError("smoothing is the causal filter: it does not go with offline=True")
        self.models = monohand.Models(hands=hands, tracking=True, model_dir=model_dir)
        self.hands = hands
        self.smoothing = smoothing
        self.offline = offline

    @daft.method(return_dtype=DataType.list(FRAME_DTYPE))
    def track(self, path: str, intrinsics: Optional[Dict[str, Any]] = None) -> List[Dict[str, Any]]:
        """Every frame of the video at ``path``, in order; or one error row."""
        frames: List[Dict[str, Any]] = []
        try:
            camera = _camera(intrinsics)
            with monohand.Session(
                camera, hands=self.hands, smoothing=self.smoothing, models=self.models
            ) as session, session.track(path, offline=self.offline) as video:
                for frame in video:
                    frames.append(
                        {
                            "frame": frame.index,
                            "time_s": frame.time_s,
                            "hands": [hand_struct(h) for h in frame.hands],
                            "error": frame.error,
                        }
                    )
        except (monohand.MonohandError, ValueError, OSError) as e:
            # Frames already tracked stay; the reason ends the video.
            frames.append({"frame": None, "time_s": None, "hands": [], "error": f"{path}: {e}"})
        if not frames:
            frames.append({"frame": None, "time_s": None, "hands": [], "error": f"{path}: no frames"})
        return frames


#: The per-video UDF class with Daft's default options (compose it yourself with
#: ``VideoTracker(hands=2).track(df["path"])``); `track_videos` sets the concurrency.
VideoTracker = daft.cls(_VideoTracker)


def track_videos(
    df: daft.DataFrame,
    path_column: str = "path",
    intrinsics_column: Optional[str] = None,
    *,
    hands: int = 2,
    model_dir: Optional[str] = None,
    smoothing: bool = False,
    workers: Optional[int] = None,
    offline: Optional[bool] = None,
) -> daft.DataFrame:
    """One row per frame of every video in ``df[path_column]``, in order within a video.

    ``offline`` (on by default for corpora, unless ``smoothing`` asks for the causal filter)
    refits each frame with the frames after it too, as ``monohand run --offline``: steadier
    hands, no lag; ``offline=False`` gives the causal output of a live run.

    ``intrinsics_column``, if given, holds a struct like `INTRINSICS_DTYPE` (or null for a
    generic camera) per video. The result keeps ``df``'s columns and adds ``frame``,
    ``time_s``, ``hands`` and ``error``.

    Each video is a batch of its own, so that ``workers`` trackers take videos side by side
    (threads: the GIL is released while they run). Default: one per core on Daft's native
    runner, Daft's own choice on Ray (where the cluster's size decides).
    """
    if workers is None and daft.get_or_infer_runner_type() == "native":
        workers = os.cpu_count() or 1
    tracker_cls = daft.cls(max_concurrency=workers, use_process=False)(_VideoTracker)
    tracker = tracker_cls(hands=hands, model_dir=model_dir, smoothing=smoothing, offline=offline)
    df = df.into_batches(1)
    path = df[path_column]
    if intrinsics_column is None:
        frames = tracker.track(path)
    else:
        frames = tracker.track(path, df[intrinsics_column])
    out = df.with_column("_monohand_frames", frames).explode("_monohand_frames")
    f = out["_monohand_frames"]
    return out.with_columns(
        {
            "frame": f["frame"],
            "time_s": f["time_s"],
            "hands": f["hands"],
            "error": f["error"],
        }
    ).exclude("_monohand_frames")


@daft.cls(max_concurrency=None)
class HandImages:
    """Hands in independent images (no tracking): one extra landmark pass per hand, and a
    generic camera per image size."""

    def __init__(self, hands: int = 2, model_dir: Optional[str] = None):
        self.models = monohand.Models(hands=hands, tracking=False, model_dir=model_dir)
        self.hands = hands
        self.sessions: Dict[Any, monohand.Session] = {}

    def _session(self, size: Any) -> monohand.Session:
        """The session for one image size (a generic camera of that size)."""
        s = self.sessions.get(size)
        if s is None:
            s = monohand.Session(None, hands=self.hands, tracking=False, models=self.models)
            self.sessions[size] = s
        return s

    @daft.method.batch(return_dtype=HANDS_DTYPE, batch_size=16)
    def track(self, images: daft.Series) -> List[List[Dict[str, Any]]]:
        """The hands of each image (an empty list for an image that cannot be used)."""
        import numpy as np

        out: List[List[Dict[str, Any]]] = []
        for arr in images.to_pylist():
            if arr is None:
                out.append([])
                continue
            rgb = np.ascontiguousarray(np.asarray(arr), dtype=np.uint8)
            if rgb.ndim != 3 or rgb.shape[2] != 3:
                out.append([])
                continue
            session = self._session(rgb.shape[:2])
            out.append([hand_struct(h) for h in session.process(rgb)])
        return out


def track_images(images: Expression, *, hands: int = 2, model_dir: Optional[str] = None) -> Expression:
    """The hands of each image of an RGB image column, as `HANDS_DTYPE` (the shape of
    ``daft_physical_ai.hands.track_hands``'s output, with metric 3D added)."""
    return HandImages(hands=hands, model_dir=model_dir).track(images)
