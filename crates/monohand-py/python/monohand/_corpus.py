"""One video of a corpus job into a Parquet file of its own, complete or absent.

The frames stream from `Session.track` into row groups of `ROW_GROUP` frames, so no video is
held in memory whole. Frames are turned into Arrow every `CHUNK` frames, so at most that many
are Python objects at once; a row group waits as compact Arrow columns. The file is written
under a temporary name and renamed when the video has ended well; a video that fails
half-way keeps its good frames in `<video_id>.partial.parquet`.
Each finished file carries its summary row in its Parquet metadata, so that a rerun can skip
the video and still give its row in `_videos.parquet`.

An output that cannot be written (a full disk) is not the video's fault: the temporary file
is removed and the row says `OUTPUT_FAILED`, which stops the job (`monohand.daft`).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from typing import Any, Callable, Dict, List, Optional

import monohand

#: Frames per Parquet row group.
ROW_GROUP = 2000
#: Frames held as Python objects before they become Arrow columns (a divisor of ROW_GROUP).
CHUNK = 250
#: The key of the summary row in a video file's Parquet metadata.
SUMMARY_KEY = b"monohand.summary"
#: The summary file of a corpus job.
SUMMARY_FILE = "_videos.parquet"
#: The status of a video whose output could not be written (never in the summary: the
#: job stops on it).
OUTPUT_FAILED = "output-failed"


class _WriteFailed(Exception):
    """Writing the video's file failed (its cause: the OSError)."""


def reason(path: str, error: BaseException) -> str:
    """Why the video at `path` failed, naming the file once: monohand's errors about a
    file begin with its name already, others get it put before them."""
    text = str(error)
    return text if path in text else f"{path}: {text}"


def video_id(path: str) -> str:
    """A stable id of a video file: its absolute path, size and modification time."""
    st = os.stat(path)
    key = f"{os.path.abspath(path)}\0{st.st_size}\0{st.st_mtime_ns}"
    return hashlib.sha1(key.encode()).hexdigest()[:16]


def output_path(out_dir: str, vid: str) -> str:
    return os.path.join(out_dir, f"{vid}.parquet")


def episode_path(out_dir: str, vid: str) -> str:
    """Where a video's LeRobot episode goes (a one-episode dataset, whole or absent)."""
    return os.path.join(out_dir, f"{vid}.lerobot")


def summary_of_done(out_dir: str, vid: str) -> Optional[Dict[str, Any]]:
    """The summary row of a finished video, or None if it is not finished."""
    import pyarrow.parquet as pq

    path = output_path(out_dir, vid)
    if not os.path.isfile(path):
        return None
    # The file's key-value metadata (`read_schema` gives the Arrow schema's, without it).
    meta = pq.read_metadata(path).metadata or {}
    raw = meta.get(SUMMARY_KEY)
    return None if raw is None else json.loads(raw)


def frame_schema() -> Any:
    """The pyarrow schema of a video file's rows."""
    import pyarrow as pa

    from monohand._dtypes import HANDS_DTYPE

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
    lerobot_task: Optional[str] = None,
) -> Dict[str, Any]:
    """Tracks the video at `path` into `out_dir` and returns its summary row; with
    `lerobot_task`, also its LeRobot episode (`episode_path`)."""
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
    batch: List[Dict[str, Any]] = []
    # The row group being gathered, as Arrow tables of CHUNK frames each.
    pending: List[Any] = []
    # Running totals only: nothing per frame outlives its row group.
    reprojection_sum, reprojection_n = 0.0, 0
    writer = None

    def to_arrow() -> None:
        if batch:
            pending.append(pa.Table.from_pylist(batch, schema=schema))
            batch.clear()

    def flush() -> None:
        to_arrow()
        if pending:
            try:
                writer.write_table(pa.concat_tables(pending), row_group_size=ROW_GROUP)
            except OSError as e:
                raise _WriteFailed(tmp) from e
            pending.clear()
            # pyarrow's allocator keeps what the row group freed; give it back, so that the
            # worker's resident memory does not keep the largest row group's.
            pa.default_memory_pool().release_unused()

    try:
        try:
            # Dictionaries only for the two string columns: on the floats of the hands
            # pyarrow's default (a dictionary for every column, until it outgrows a page)
            # cost 60 MB of memory per row group and made the file 40% larger.
            writer = pq.ParquetWriter(tmp, schema, use_dictionary=["path", "video_id"])
        except OSError as e:
            raise _WriteFailed(tmp) from e
        try:
            episode = None
            if lerobot_task is not None:
                episode = episode_path(out_dir, vid)
                # An earlier attempt's: never part of the dataset, made again.
                shutil.rmtree(episode, ignore_errors=True)
            with session() as s, s.track(path, offline=offline, lerobot=episode, lerobot_task=lerobot_task or "") as video:
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
                    for h in hands:
                        if h["reprojection_error_px"] is not None:
                            reprojection_sum += h["reprojection_error_px"]
                            reprojection_n += 1
                    if len(batch) >= CHUNK:
                        to_arrow()
                        if sum(t.num_rows for t in pending) >= ROW_GROUP:
                            flush()
            row["status"] = "done"
        except (monohand.MonohandError, ValueError, OSError) as e:
            row["reason"] = reason(path, e)
        flush()
        if reprojection_n:
            row["mean_reprojection_px"] = reprojection_sum / reprojection_n
        try:
            if row["status"] == "done":
                writer.add_key_value_metadata({SUMMARY_KEY.decode(): json.dumps(row, sort_keys=True)})
            writer.close()
        except OSError as e:
            raise _WriteFailed(tmp) from e
    except _WriteFailed as e:
        # Not the video's fault, and every later video would fail the same way.
        _discard(writer, tmp)
        row["status"] = OUTPUT_FAILED
        row["reason"] = f"{e.args[0]}: {e.__cause__}"
        row["errno"] = getattr(e.__cause__, "errno", None)
        return row
    if row["status"] == "done":
        os.replace(tmp, output_path(out_dir, vid))
    elif row["frames"] > 0:
        os.replace(tmp, os.path.join(out_dir, f"{vid}.partial.parquet"))
    else:
        os.remove(tmp)
    return row


def _discard(writer: Any, tmp: str) -> None:
    """Closes a writer whose file could not be written and removes the file: it is not
    valid Parquet (no footer), and on a full disk its space is better given back."""
    if writer is not None:
        try:
            writer.close()
        except OSError:
            pass
    try:
        os.remove(tmp)
    except OSError:
        pass
