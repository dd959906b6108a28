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

import json
import os
import sys
import time
from typing import Any, Dict, Iterable, List, Optional, Union

import daft
from daft import DataType, Expression

import monohand
# The column types: defined below this module and the corpus job (monohand._corpus), which
# both take them; monohand.daft.HAND_DTYPE and the others are these.
from monohand._dtypes import FRAME_DTYPE, HAND_DTYPE, HANDS_DTYPE, INTRINSICS_DTYPE

__all__ = [
    "CorpusOutputError",
    "FRAME_DTYPE",
    "HAND_DTYPE",
    "HANDS_DTYPE",
    "INTRINSICS_DTYPE",
    "MAX_RETRIES",
    "HandImages",
    "VideoTracker",
    "hand_struct",
    "track_corpus",
    "track_images",
    "track_videos",
]


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


def _offline(offline: Optional[bool], smoothing: bool) -> bool:
    """Corpora are tracked offline by nature, unless the causal filter is asked for."""
    if offline is None:
        offline = not smoothing
    if smoothing and offline:
        raise ValueError("smoothing is the causal filter: it does not go with offline=True")
    return offline


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
        offline = _offline(offline, smoothing)
        self.models = monohand.Models(hands=hands, tracking=True, model_dir=model_dir)
        self.hands = hands
        self.smoothing = smoothing
        self.offline = offline

    @daft.method(return_dtype=DataType.list(FRAME_DTYPE))
    def track(self, path: str, intrinsics: Optional[Dict[str, Any]] = None) -> List[Dict[str, Any]]:
        """Every frame of the video at ``path``, in order; or one error row."""
        from monohand import _corpus

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
            frames.append({"frame": None, "time_s": None, "hands": [], "error": _corpus.reason(path, e)})
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


class _CorpusTracker:
    """Tracks each video of a corpus into its own Parquet file (`monohand._corpus`)."""

    def __init__(
        self, out_dir: str, hands: int, model_dir: Optional[str], smoothing: bool, offline: bool,
        lerobot_task: Optional[str] = None,
    ):
        self.models = monohand.Models(hands=hands, tracking=True, model_dir=model_dir)
        self.out_dir, self.hands, self.smoothing, self.offline = out_dir, hands, smoothing, offline
        self.lerobot_task = lerobot_task
        self.settings = {"hands": hands, "smoothing": smoothing, "offline": offline}

    @daft.method(return_dtype=DataType.string())
    def track(self, path: str, intrinsics: Optional[Dict[str, Any]] = None) -> str:
        """The video's summary row, as JSON."""
        from monohand import _corpus

        try:
            camera = _camera(intrinsics)
        except (KeyError, TypeError, ValueError) as e:
            return json.dumps({"path": path, "status": "failed", "reason": f"{path}: intrinsics: {e}"})

        def session() -> monohand.Session:
            return monohand.Session(camera, hands=self.hands, smoothing=self.smoothing, models=self.models)

        return json.dumps(
            _corpus.track_one(
                path, self.out_dir, session, self.offline, self.settings, hand_struct, self.lerobot_task
            )
        )


#: `track_corpus`'s default for ``max_retries``: a video whose tracker dies (on Ray) is
#: run again up to this many times (Ray's own default for tasks).
MAX_RETRIES = 3


class CorpusOutputError(OSError):
    """`track_corpus` could not write to its ``out_dir`` (a full disk, a folder that cannot
    be written): the job stopped. ``errno`` is the write's (``errno.ENOSPC`` for a full
    disk); the videos finished before it are kept, and a rerun resumes from them."""


def track_corpus(
    paths_or_df: Union[daft.DataFrame, Iterable[str]],
    out_dir: str,
    path_column: str = "path",
    intrinsics_column: Optional[str] = None,
    *,
    hands: int = 2,
    model_dir: Optional[str] = None,
    smoothing: bool = False,
    offline: Optional[bool] = None,
    workers: Optional[int] = None,
    progress: bool = True,
    max_retries: int = MAX_RETRIES,
    lerobot: Optional[str] = None,
    lerobot_task: str = "human hand",
) -> Any:
    """Tracks every video of a corpus into ``out_dir``, one Parquet file per video, and
    returns the summary (a pyarrow Table, also written as ``out_dir/_videos.parquet``).

    - ``lerobot="DS"`` also makes one LeRobot v3 dataset of every finished video at ``DS``
      (`monohand run --each ... --lerobot`; docs/robots-and-xr.md): each video's episode
      is kept as ``out_dir/<video_id>.lerobot``, and ``DS`` is made again from all of them,
      in the order of the videos, at the end of each run of the job (a rerun's included); a
      video whose frame size or rate is not the first's is left out, and said.

    - ``out_dir/<video_id>.parquet`` holds `track_videos`' rows (``frame, time_s, hands,
      error``) with ``path`` and ``video_id``, streamed in row groups of a few thousand
      frames. It is written under a temporary name and renamed when the video is complete.
      ``video_id`` comes from the file's absolute path, size and modification time.
    - A video that fails is ``failed`` in the summary with the reason; its good frames stay
      in ``out_dir/<video_id>.partial.parquet``.
    - Rerunning with the same ``out_dir`` skips the finished videos and redoes the others:
      a job killed at any point and rerun gives what one uninterrupted run gives.
    - The summary has one row per video: ``path, video_id, status, reason, camera,
      camera_source, frames, frames_with_hands, hands, mean_reprojection_px, settings,
      monohand_version``.

    ``offline`` (default: on unless ``smoothing``) and the other options are `track_videos`'.
    ``progress`` prints one line per finished video with the time left, on stderr.

    ``max_retries`` (default `MAX_RETRIES`, on Ray): how many times Ray starts a tracker
    again whose process died (killed, out of memory, its node lost) and reruns the video it
    had: the trackers run as Ray actors with ``max_restarts`` and ``max_task_retries`` set
    to it; -1 is without end. Past that, Daft 0.7.26 does not fail the job but waits (seen
    with 0: still waiting after 10 minutes), so keep it at 1 or more.

    A write that fails (a full disk) raises `CorpusOutputError` and stops the job; the
    finished videos are kept.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    from monohand import _corpus

    offline = _offline(offline, smoothing)
    if max_retries < -1:
        raise ValueError(f"max_retries must be -1 (without end) or at least 0, not {max_retries}")
    os.makedirs(out_dir, exist_ok=True)
    if isinstance(paths_or_df, daft.DataFrame):
        cols = [path_column] + ([intrinsics_column] if intrinsics_column else [])
        videos = paths_or_df.select(*cols).to_pylist()
    else:
        videos = [{path_column: str(p)} for p in paths_or_df]
    summary: List[Dict[str, Any]] = []
    todo: List[Dict[str, Any]] = []
    for v in videos:
        try:
            done = _corpus.summary_of_done(out_dir, _corpus.video_id(v[path_column]))
        except OSError:
            done = None
        if done is not None and lerobot is not None:
            episode = _corpus.episode_path(out_dir, done["video_id"])
            if not os.path.isfile(os.path.join(episode, "meta", "info.json")):
                done = None
        if done is None:
            todo.append(v)
        else:
            summary.append(done)
    if progress:
        print(f"monohand: {len(videos)} videos, {len(summary)} already done", file=sys.stderr)
    if todo:
        on_ray = daft.get_or_infer_runner_type() == "ray"
        if workers is None and not on_ray:
            workers = os.cpu_count() or 1
        # On Ray, Ray's own fault tolerance for the trackers' actors (see the docstring).
        ray_options = {"max_restarts": max_retries, "max_task_retries": max_retries} if on_ray else None
        tracker_cls = daft.cls(max_concurrency=workers, use_process=False, ray_options=ray_options)(_CorpusTracker)
        task = lerobot_task if lerobot is not None else None
        tracker = tracker_cls(out_dir, hands, model_dir, smoothing, offline, task)
        df = daft.from_pylist(todo).into_batches(1)
        args = [df[path_column]] + ([df[intrinsics_column]] if intrinsics_column else [])
        results = df.select(tracker.track(*args).alias("_summary"))
        start = time.monotonic()
        for k, r in enumerate(results.iter_rows(), 1):
            row = json.loads(r["_summary"])
            if row["status"] == _corpus.OUTPUT_FAILED:
                _stop_on_output(row["reason"], row.get("errno"), out_dir, summary)
            summary.append(row)
            if progress:
                spent = time.monotonic() - start
                left = spent / k * (len(todo) - k)
                # The line names the video already: its reason without the name.
                reason = row.get("reason") or ""
                reason = reason[len(row["path"]) + 2 :] if reason.startswith(f"{row['path']}: ") else reason
                what = f"{row['frames']} frames" if row["status"] == "done" else reason
                print(
                    f"monohand: [{k}/{len(todo)}] {row['path']}: {row['status']} ({what}); "
                    f"{spent:.0f} s spent, about {left:.0f} s left",
                    file=sys.stderr,
                )
    # Temporary files of attempts that died (a killed worker whose video Ray ran again).
    ids = {r.get("video_id") for r in summary}
    for name in os.listdir(out_dir):
        if name.endswith(".parquet.tmp") and name.split(".")[1] in ids:
            os.remove(os.path.join(out_dir, name))
    order = {v[path_column]: i for i, v in enumerate(videos)}
    summary.sort(key=lambda r: order.get(r.get("path"), len(order)))
    table = pa.Table.from_pylist([_summary_row(r) for r in summary], schema=_summary_schema())
    tmp = os.path.join(out_dir, f".{_corpus.SUMMARY_FILE}.{os.getpid()}.tmp")
    try:
        pq.write_table(table, tmp)
    except OSError as e:
        if os.path.exists(tmp):
            os.remove(tmp)
        _stop_on_output(f"{tmp}: {e}", e.errno, out_dir, summary)
    os.replace(tmp, os.path.join(out_dir, _corpus.SUMMARY_FILE))
    if lerobot is not None:
        _lerobot_dataset(summary, out_dir, lerobot, progress)
    return table


def _lerobot_dataset(summary: List[Dict[str, Any]], out_dir: str, lerobot: str, progress: bool) -> None:
    """`track_corpus(lerobot=...)`'s dataset of the finished videos' episodes."""
    from monohand import _corpus

    parts = [_corpus.episode_path(out_dir, r["video_id"]) for r in summary if r.get("status") == "done"]
    if not parts:
        if progress:
            print(f"monohand: lerobot {lerobot}: no video done, no dataset", file=sys.stderr)
        return
    made = monohand.lerobot_dataset(parts, lerobot)
    if progress:
        for part, why in made["left_out"]:
            print(f"monohand: lerobot: {part} left out: {why}", file=sys.stderr)
        print(f"monohand: lerobot {lerobot}: {made['episodes']} episodes, {made['frames']} frames", file=sys.stderr)


def _stop_on_output(reason: str, code: Optional[int], out_dir: str, summary: List[Dict[str, Any]]) -> None:
    """Raises `CorpusOutputError` for a write that failed (``reason``: the file and the
    OSError's text; ``code``: its errno), saying what is kept."""
    import errno

    done = sum(1 for r in summary if r.get("status") == "done")
    full = " (the disk is full)" if code == errno.ENOSPC else ""
    raise CorpusOutputError(
        code or errno.EIO,
        f"monohand: the corpus output could not be written{full}: {reason}. The job stopped; "
        f"the {done} videos finished are kept in {out_dir}, and rerunning the job there "
        "resumes from them.",
    )


def _summary_schema() -> Any:
    import pyarrow as pa

    camera = pa.struct(
        [("fx", pa.float64()), ("fy", pa.float64()), ("cx", pa.float64()), ("cy", pa.float64()),
         ("width", pa.int64()), ("height", pa.int64())]
    )
    return pa.schema(
        [
            ("path", pa.string()),
            ("video_id", pa.string()),
            ("status", pa.string()),
            ("reason", pa.string()),
            ("camera", camera),
            ("camera_source", pa.string()),
            ("frames", pa.int64()),
            ("frames_with_hands", pa.int64()),
            ("hands", pa.int64()),
            ("mean_reprojection_px", pa.float64()),
            ("settings", pa.string()),
            ("monohand_version", pa.string()),
        ]
    )


def _summary_row(r: Dict[str, Any]) -> Dict[str, Any]:
    names = _summary_schema().names
    return {k: r.get(k) for k in names}


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
