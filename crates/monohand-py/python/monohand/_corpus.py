"""One video of a corpus job into a Parquet file of its own, complete or absent.

The frames stream from `Session.track` into row groups of `ROW_GROUP` frames, so no video is
held in memory whole. The file is written under a temporary name and renamed when the video
has ended well; a video that fails half-way keeps its good frames in `<video_id>.partial.parquet`.
Each finished file carries its summary row in its Parquet metadata, so that a rerun can skip
the video and still give its row in `_videos.parquet`.
"""

from __future__ import annotations

import hashlib
import json
import os
from typing import Any, Callable, Dict, List, Optional

import monohand

#: Frames per Parquet row group.
ROW_GROUP = 2000
#: The key of the summary row in a video file's Parquet metadata.
SUMMARY_KEY = b"monohand.summary"
#: The summary file of a corpus job.
SUMMARY_FILE = "_videos.parquet"


def video_id(path: str) -> str:
    """A stable id of a video file: its absolute path, size and modification time."""
    st = os.stat(path)
    key = f"{os.path.abspath(path)}\0{st.st_size}\0{st.st_mtime_ns}"
    return hashlib.sha1(key.encode()).hexdigest()[:16]


def output_path(out_dir: str, vid: str) -> str:
    return os.path.join(out_dir, f"{vid}.parquet")


def summary_of_done(out_dir: str, vid: str) -> Optional[Dict[str, Any]]:
    """The summary row of a finished video, or None if it is not finished."""
    import pyarrow.parquet as pq

    path = output_path(out_dir, vid)
    if not os.path.isfile(path):
        return None
    meta = pq.read_schema(path).metadata or {}
    raw = meta.get(SUMMARY_KEY)
    return None if raw is None else json.loads(raw)


def frame_schema() -> Any:
    """The pyarrow schema of a video file's rows."""
    import pyarrow as pa

    from monohand.daft import HANDS_DTYPE

    return pa.schema(
        [
            ("path", pa.large_string()),
            ("video_id", pa.large_string()),
            ("frame", pa.int64()),
            ("time_s", pa.float64()),
            ("hands", HANDS_DTYPE.to_arrow_dtype()),
            ("error", pa.large_string()),
        ]
    )


def track_one(
    path: str,
    out_dir: str,
    session: Callable[[], "monohand.Session"],
    offline: bool,
    settings: Dict[str, Any],
    hand_struct: Callable[[Any], Dict[str, Any]],
) -> Dict[str, Any]:
    """Tracks the video at `path` into `out_dir` and returns its summary row."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    row: Dict[str, Any] = {
        "path": path,
        "video_id": None,
        "status": "failed",
        "reason": None,
        "camera": None,
        "camera_source": None,
        "frames": 0,
        "frames_with_hands": 0,
        "hands": 0,
        "mean_reprojection_px": None,
        "settings": json.dumps(settings, sort_keys=True),
        "monohand_version": monohand.__version__,
    }
    try:
        vid = video_id(path)
    except OSError as e:
        row["reason"] = f"{path}: {e.strerror or e}"
        return row
    row["video_id"] = vid
    schema = frame_schema()
    tmp = os.path.join(out_dir, f".{vid}.{os.getpid()}.parquet.tmp")
    writer = pq.ParquetWriter(tmp, schema)
    batch: List[Dict[str, Any]] = []
    reprojection: List[float] = []

    def flush() -> None:
        if batch:
            writer.write_table(pa.Table.from_pylist(batch, schema=schema), row_group_size=ROW_GROUP)
            batch.clear()

    try:
        with session() as s, s.track(path, offline=offline) as video:
            for frame in video:
                hands = [hand_struct(h) for h in frame.hands]
                if row["camera"] is None and frame.cameras:
                    cam = dict(frame.cameras[0])
                    row["camera_source"] = cam.pop("source", None)
                    cam.pop("reason", None)
                    row["camera"] = cam
                batch.append(
                    {"path": path, "video_id": vid, "frame": frame.index, "time_s": frame.time_s,
                     "hands": hands, "error": frame.error}
                )
                row["frames"] += 1
                row["frames_with_hands"] += bool(hands)
                row["hands"] += len(hands)
                reprojection += [h["reprojection_error_px"] for h in hands if h["reprojection_error_px"] is not None]
                if len(batch) >= ROW_GROUP:
                    flush()
        row["status"] = "done"
    except (monohand.MonohandError, ValueError, OSError) as e:
        row["reason"] = str(e) if path in str(e) else f"{path}: {e}"
    flush()
    if reprojection:
        row["mean_reprojection_px"] = sum(reprojection) / len(reprojection)
    if row["status"] == "done":
        writer.add_key_value_metadata({SUMMARY_KEY.decode(): json.dumps(row, sort_keys=True)})
        writer.close()
        os.replace(tmp, output_path(out_dir, vid))
    else:
        writer.close()
        if row["frames"] > 0:
            os.replace(tmp, os.path.join(out_dir, f"{vid}.partial.parquet"))
        else:
            os.remove(tmp)
    return row
