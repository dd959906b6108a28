//! LeRobot v3 datasets of tracked hands (`monohand run --lerobot DIR`): the layout, the
//! state vector and the tables, as LeRobot's `LeRobotDataset` (codebase `v3.0`) reads them.
//!
//! ```text
//! DIR/meta/info.json                         fps, features, path templates, the cameras ("monohand")
//! DIR/meta/stats.json                        per feature: min, max, mean, std, count
//! DIR/meta/tasks.parquet                     the task's text and its index
//! DIR/meta/episodes/chunk-000/file-000.parquet   the episode: length, rows, video span
//! DIR/data/chunk-000/file-000.parquet        a row per frame: observation.state, action, ...
//! DIR/videos/observation.images.view1/chunk-000/file-000.mp4   episode 0's frames (the caller encodes them)
//! ```
//!
//! A dataset of several episodes ([`assemble`]) keeps every frame in one data file and each
//! episode's video in a file of its own (`file-001.mp4` for episode 1, 1000 to a chunk).
//!
//! The state ([`state_names`]) is both hands, left then right, each `valid` (1 when the hand
//! was fitted in 3D, else 0 and the hand's values 0), its 21 joints in metres in the first
//! camera's frame (in [`JOINT_NAMES`] order) and its wrist pose (position in metres and
//! orientation as a quaternion `x, y, z, w`, MANO's wrist frame:
//! [`monohand_core::wrist`]). `action` is the next frame's state (the last frame's own).
//! This module writes plain data; which hand goes where is the caller's.

mod stats;
mod table;

pub use stats::{Moments, Summary};

use crate::error::IoError;
use crate::jsonl::{CameraRecord, HandSizeRecord};
use monohand_core::hand_model::{HandSide, JOINT_NAMES, NUM_JOINTS};
use parquet::format::KeyValue;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use table::{read_float_lists, write_table, Column};

/// The LeRobot dataset format written (`info.json`'s `codebase_version`).
pub const CODEBASE_VERSION: &str = "v3.0";
/// `info.json`'s `robot_type`: a human hand seen by cameras.
pub const ROBOT_TYPE: &str = "human_hand";
/// Episodes' video files to a chunk folder (`chunks_size`).
pub const CHUNK_SIZE: usize = 1000;
/// The data file, relative to the dataset.
pub const DATA_FILE: &str = "data/chunk-000/file-000.parquet";
/// The episodes' file, relative to the dataset.
pub const EPISODES_FILE: &str = "meta/episodes/chunk-000/file-000.parquet";
/// Values per hand in the state: `valid`, 21 joints x 3, the wrist's position and quaternion.
pub const HAND_STATE_LEN: usize = 1 + 3 * NUM_JOINTS + 7;
/// The state's length: two hands.
pub const STATE_LEN: usize = 2 * HAND_STATE_LEN;

/// The video feature of view `view` (from 1): `observation.images.view1`, ...
pub fn video_key(view: usize) -> String {
    format!("observation.images.view{view}")
}

/// Where view `view`'s video of episode `episode` goes, relative to the dataset.
pub fn video_file(view: usize, episode: usize) -> String {
    format!(
        "videos/{}/chunk-{:03}/file-{:03}.mp4",
        video_key(view),
        episode / CHUNK_SIZE,
        episode % CHUNK_SIZE
    )
}

/// The names of the state's values, in order (also `action`'s).
pub fn state_names() -> Vec<String> {
    let mut names = Vec::with_capacity(STATE_LEN);
    for side in ["left", "right"] {
        names.push(format!("{side}.valid"));
        for joint in JOINT_NAMES {
            for axis in ["x", "y", "z"] {
                names.push(format!("{side}.{joint}.{axis}_m"));
            }
        }
        for v in ["x_m", "y_m", "z_m", "qx", "qy", "qz", "qw"] {
            names.push(format!("{side}.wrist_pose.{v}"));
        }
    }
    names
}

/// One hand as the state holds it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandState {
    /// The 21 joints, metres, the first camera's frame.
    pub joints_m: [[f64; 3]; NUM_JOINTS],
    /// The wrist's position, metres.
    pub wrist_m: [f64; 3],
    /// The wrist frame's orientation, `x, y, z, w`.
    pub wrist_quaternion_xyzw: [f64; 4],
}

/// A frame's state: each side's hand, or nothing where no hand of that side was fitted.
pub fn frame_state(left: Option<&HandState>, right: Option<&HandState>) -> Vec<f32> {
    let mut state = vec![0.0f32; STATE_LEN];
    for (slot, hand) in state.chunks_exact_mut(HAND_STATE_LEN).zip([left, right]) {
        let Some(h) = hand else { continue };
        slot[0] = 1.0;
        let values = h
            .joints_m
            .iter()
            .flatten()
            .chain(&h.wrist_m)
            .chain(&h.wrist_quaternion_xyzw);
        for (s, v) in slot[1..].iter_mut().zip(values) {
            *s = *v as f32;
        }
    }
    state
}

/// The state slot of a side (left first).
pub fn side_slot(side: HandSide) -> usize {
    match side {
        HandSide::Left => 0,
        HandSide::Right => 1,
    }
}

/// One view's video of an episode, as encoded by the caller.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoInfo {
    /// Frame width, pixels.
    pub width: u32,
    /// Frame height, pixels.
    pub height: u32,
    /// The codec's name as LeRobot states it (`h264`, `mpeg4`).
    pub codec: String,
    /// Per channel (R, G, B), the pixels' statistics in `[0, 1]`, counted in frames.
    pub stats: [Summary; 3],
}

/// One episode: its frames' states, its videos and what `info.json` says of the capture.
#[derive(Debug, Clone, PartialEq)]
pub struct Episode {
    /// Frames per second (LeRobot's are whole numbers); frame `i` is at `i / fps`.
    pub fps: u32,
    /// The task's text.
    pub task: String,
    /// Each frame's state ([`frame_state`]).
    pub states: Vec<Vec<f32>>,
    /// The videos, view 1 first (already written at [`video_file`]).
    pub videos: Vec<VideoInfo>,
    /// The camera of each view, as the last frame was fitted with.
    pub cameras: Vec<CameraRecord>,
    /// The hand size the fit used, if it said.
    pub hand_size: Option<HandSizeRecord>,
    /// What the episode was made from (a video's file name), if known.
    pub source: Option<String>,
}

fn write_json(path: &Path, value: &Value) -> Result<(), IoError> {
    let text = serde_json::to_string_pretty(value).unwrap_or_default() + "\n";
    std::fs::write(path, text).map_err(|error| IoError::Write {
        path: path.to_path_buf(),
        error,
    })
}

fn read_json(path: &Path) -> Result<Value, IoError> {
    let text = std::fs::read_to_string(path).map_err(|error| IoError::Read {
        path: path.to_path_buf(),
        error,
    })?;
    serde_json::from_str(&text).map_err(|e| IoError::Json {
        file: path.display().to_string(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })
}

fn format_error(path: &Path, message: impl Into<String>) -> IoError {
    IoError::Format {
        file: path.display().to_string(),
        message: message.into(),
    }
}

/// `dir/rel`, its folder made.
fn file_in(dir: &Path, rel: &str) -> Result<PathBuf, IoError> {
    let p = dir.join(rel);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).map_err(|error| IoError::Write {
            path: parent.to_path_buf(),
            error,
        })?;
    }
    Ok(p)
}

/// pandas' footer metadata of a table whose index is the text column `index`: what
/// `pandas.read_parquet` needs to give the tasks back indexed by their text, as LeRobot
/// reads them.
fn pandas_index_metadata(index: &str, other: &str) -> KeyValue {
    let meta = json!({
        "index_columns": [index],
        "column_indexes": [{"name": null, "field_name": null, "pandas_type": "unicode",
                            "numpy_type": "object", "metadata": {"encoding": "UTF-8"}}],
        "columns": [
            {"name": other, "field_name": other, "pandas_type": "int64",
             "numpy_type": "int64", "metadata": null},
            {"name": index, "field_name": index, "pandas_type": "unicode",
             "numpy_type": "object", "metadata": null},
        ],
        "creator": {"library": "monohand", "version": env!("CARGO_PKG_VERSION")},
        "pandas_version": "2.2.0",
    });
    KeyValue::new("pandas".to_string(), meta.to_string())
}

/// Writes a one-episode dataset's tables and metadata into `dir`, whose videos are already
/// at [`video_file`] (episode 0); `meta/info.json` last.
pub fn write_episode(dir: &Path, episode: &Episode) -> Result<(), IoError> {
    write_dataset(dir, std::slice::from_ref(episode))
}

/// Writes the tables and the metadata of a dataset of `episodes` into `dir`, whose videos
/// are already at [`video_file`]; `meta/info.json` last, so that a folder without it was
/// not finished. The episodes must share the frame rate, the views and their frame sizes
/// (LeRobot's features have one shape); one without frames is refused.
pub fn write_dataset(dir: &Path, episodes: &[Episode]) -> Result<(), IoError> {
    let Some(first) = episodes.first() else {
        return Err(format_error(
            dir,
            "a LeRobot dataset needs at least one episode",
        ));
    };
    for (k, e) in episodes.iter().enumerate() {
        if e.states.is_empty() || e.fps == 0 {
            return Err(format_error(
                dir,
                format!("episode {k} has no frames or no frame rate"),
            ));
        }
        if let Some(why) = mismatch(first, e) {
            return Err(format_error(dir, format!("episode {k}: {why}")));
        }
    }
    let fps = f64::from(first.fps);
    let mut tasks: Vec<String> = Vec::new();
    let task_of: Vec<i64> = episodes
        .iter()
        .map(|e| {
            let at = tasks.iter().position(|t| *t == e.task).unwrap_or_else(|| {
                tasks.push(e.task.clone());
                tasks.len() - 1
            });
            at as i64
        })
        .collect();
    let rows = Rows::of(episodes, &task_of, fps);
    let total = rows.states.len();
    write_table(
        &file_in(dir, DATA_FILE)?,
        &[
            ("observation.state", Column::FloatList(&rows.states)),
            ("action", Column::FloatList(&rows.actions)),
            ("timestamp", Column::Float(rows.times.clone())),
            ("frame_index", Column::Int(rows.frame_index.clone())),
            ("episode_index", Column::Int(rows.episode_index.clone())),
            ("index", Column::Int((0..total as i64).collect())),
            ("task_index", Column::Int(rows.task_index.clone())),
        ],
        Vec::new(),
    )?;
    write_episodes_table(dir, episodes, &rows.starts, fps)?;
    write_table(
        &file_in(dir, "meta/tasks.parquet")?,
        &[
            ("task_index", Column::Int((0..tasks.len() as i64).collect())),
            ("task", Column::Text(tasks.clone())),
        ],
        vec![pandas_index_metadata("task", "task_index")],
    )?;
    write_json(&file_in(dir, "meta/stats.json")?, &rows.stats(episodes))?;
    write_json(
        &file_in(dir, "meta/info.json")?,
        &info(episodes, &tasks, total),
    )
}

/// The data file's columns: every episode's frames in turn.
struct Rows {
    states: Vec<Vec<f32>>,
    actions: Vec<Vec<f32>>,
    times: Vec<f32>,
    frame_index: Vec<i64>,
    episode_index: Vec<i64>,
    task_index: Vec<i64>,
    /// Each episode's first row.
    starts: Vec<i64>,
}

impl Rows {
    fn of(episodes: &[Episode], task_of: &[i64], fps: f64) -> Rows {
        let mut r = Rows {
            states: Vec::new(),
            actions: Vec::new(),
            times: Vec::new(),
            frame_index: Vec::new(),
            episode_index: Vec::new(),
            task_index: Vec::new(),
            starts: Vec::with_capacity(episodes.len()),
        };
        for (k, e) in episodes.iter().enumerate() {
            r.starts.push(r.states.len() as i64);
            let n = e.states.len();
            r.states.extend(e.states.iter().cloned());
            r.actions
                .extend((0..n).map(|i| e.states[(i + 1).min(n - 1)].clone()));
            r.times.extend((0..n).map(|i| (i as f64 / fps) as f32));
            r.frame_index.extend(0..n as i64);
            r.episode_index.extend(std::iter::repeat_n(k as i64, n));
            r.task_index.extend(std::iter::repeat_n(task_of[k], n));
        }
        r
    }

    /// `meta/stats.json`: every feature's, the images' pooled from the episodes'.
    fn stats(&self, episodes: &[Episode]) -> Value {
        let total = self.states.len();
        let scalar = |v: &[f64]| {
            let mut m = Moments::default();
            v.iter().for_each(|x| m.add(*x));
            stats::entry(&[m.summary(v.len() as u64)], v.len() as u64, |x| json!(x))
        };
        let as_f64 = |v: &[i64]| v.iter().map(|x| *x as f64).collect::<Vec<f64>>();
        let vector = |rows: &[Vec<f32>]| {
            stats::entry(&stats::columns(rows), rows.len() as u64, |x| json!(x))
        };
        let mut all = serde_json::Map::new();
        all.insert("observation.state".into(), vector(&self.states));
        all.insert("action".into(), vector(&self.actions));
        let times: Vec<f64> = self.times.iter().map(|t| f64::from(*t)).collect();
        all.insert("timestamp".into(), scalar(&times));
        all.insert("frame_index".into(), scalar(&as_f64(&self.frame_index)));
        let index: Vec<f64> = (0..total).map(|i| i as f64).collect();
        all.insert("index".into(), scalar(&index));
        all.insert("episode_index".into(), scalar(&as_f64(&self.episode_index)));
        all.insert("task_index".into(), scalar(&as_f64(&self.task_index)));
        for v in 0..episodes[0].videos.len() {
            let channels: Vec<Summary> = (0..3)
                .map(|c| {
                    let parts: Vec<Summary> =
                        episodes.iter().map(|e| e.videos[v].stats[c]).collect();
                    Summary::pooled(&parts)
                })
                .collect();
            let entry = stats::entry(&channels, total as u64, |x| json!([[x]]));
            all.insert(video_key(v + 1), entry);
        }
        Value::Object(all)
    }
}

/// `meta/episodes/chunk-000/file-000.parquet`: a row per episode, where its rows and its
/// videos are.
fn write_episodes_table(
    dir: &Path,
    episodes: &[Episode],
    starts: &[i64],
    fps: f64,
) -> Result<(), IoError> {
    let ints = |f: &dyn Fn(usize) -> i64| Column::Int((0..episodes.len()).map(f).collect());
    let len = |k: usize| episodes[k].states.len() as i64;
    let mut columns: Vec<(String, Column<'_>)> = vec![
        ("episode_index".into(), ints(&|k| k as i64)),
        (
            "tasks".into(),
            Column::TextList(episodes.iter().map(|e| vec![e.task.clone()]).collect()),
        ),
        ("length".into(), ints(&len)),
        ("data/chunk_index".into(), ints(&|_| 0)),
        ("data/file_index".into(), ints(&|_| 0)),
        ("dataset_from_index".into(), ints(&|k| starts[k])),
        ("dataset_to_index".into(), ints(&|k| starts[k] + len(k))),
    ];
    for v in 1..=episodes[0].videos.len() {
        let key = video_key(v);
        columns.push((
            format!("videos/{key}/chunk_index"),
            ints(&|k| (k / CHUNK_SIZE) as i64),
        ));
        columns.push((
            format!("videos/{key}/file_index"),
            ints(&|k| (k % CHUNK_SIZE) as i64),
        ));
        columns.push((
            format!("videos/{key}/from_timestamp"),
            Column::Double(vec![0.0; episodes.len()]),
        ));
        columns.push((
            format!("videos/{key}/to_timestamp"),
            Column::Double(
                episodes
                    .iter()
                    .map(|e| e.states.len() as f64 / fps)
                    .collect(),
            ),
        ));
    }
    columns.push(("meta/episodes/chunk_index".into(), ints(&|_| 0)));
    columns.push(("meta/episodes/file_index".into(), ints(&|_| 0)));
    write_table(&file_in(dir, EPISODES_FILE)?, &columns, Vec::new())
}

/// `meta/info.json`.
fn info(episodes: &[Episode], tasks: &[String], frames: usize) -> Value {
    let first = &episodes[0];
    let names = state_names();
    let scalar = |dtype: &str| json!({"dtype": dtype, "shape": [1], "names": null});
    let mut features = serde_json::Map::new();
    for key in ["observation.state", "action"] {
        features.insert(
            key.into(),
            json!({"dtype": "float32", "shape": [STATE_LEN], "names": names}),
        );
    }
    for (v, video) in first.videos.iter().enumerate() {
        features.insert(
            video_key(v + 1),
            json!({
                "dtype": "video",
                "shape": [video.height, video.width, 3],
                "names": ["height", "width", "channels"],
                "info": {
                    "video.height": video.height, "video.width": video.width,
                    "video.codec": video.codec, "video.pix_fmt": "yuv420p",
                    "video.is_depth_map": false, "video.fps": first.fps,
                    "video.channels": 3, "has_audio": false,
                },
            }),
        );
    }
    features.insert("timestamp".into(), scalar("float32"));
    for key in ["frame_index", "episode_index", "index", "task_index"] {
        features.insert(key.into(), scalar("int64"));
    }
    let per_episode: Vec<Value> = episodes
        .iter()
        .enumerate()
        .map(|(k, e)| {
            json!({"episode_index": k, "source": e.source, "task": e.task,
                   "cameras": e.cameras, "hand_size": e.hand_size})
        })
        .collect();
    json!({
        "codebase_version": CODEBASE_VERSION,
        "robot_type": ROBOT_TYPE,
        "total_episodes": episodes.len(),
        "total_frames": frames,
        "total_tasks": tasks.len(),
        "chunks_size": CHUNK_SIZE,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 200,
        "fps": first.fps,
        "splits": {"train": format!("0:{}", episodes.len())},
        "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
        "video_path": if first.videos.is_empty() { Value::Null } else {
            json!("videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4")
        },
        "features": features,
        "monohand": {
            "version": env!("CARGO_PKG_VERSION"),
            "state": "both hands, left then right: valid, the 21 joints' x, y, z (metres, the \
                      first camera's frame: x right, y down, z forward), the wrist pose's x, y, z \
                      (metres) and quaternion qx, qy, qz, qw (MANO's wrist frame); action: the \
                      next frame's state",
            "episodes": per_episode,
        },
    })
}

/// Reads back a one-episode dataset that [`write_episode`] wrote (its videos stay where
/// they are, at [`video_file`] of episode 0).
pub fn read_episode(dir: &Path) -> Result<Episode, IoError> {
    let info_path = dir.join("meta/info.json");
    let info = read_json(&info_path)?;
    let stats = read_json(&dir.join("meta/stats.json"))?;
    let bad = |what: &str| {
        format_error(
            &info_path,
            format!("not monohand's one-episode dataset: {what}"),
        )
    };
    if info["total_episodes"].as_u64() != Some(1) {
        return Err(bad("total_episodes is not 1"));
    }
    let meta = &info["monohand"]["episodes"][0];
    let fps = info["fps"]
        .as_u64()
        .and_then(|f| u32::try_from(f).ok())
        .ok_or_else(|| bad("fps"))?;
    let mut videos = Vec::new();
    for v in 1.. {
        let key = video_key(v);
        let feature = &info["features"][&key];
        if feature.is_null() {
            break;
        }
        let dim = |i: usize| {
            feature["shape"][i]
                .as_u64()
                .and_then(|x| u32::try_from(x).ok())
        };
        videos.push(VideoInfo {
            height: dim(0).ok_or_else(|| bad("a video's shape"))?,
            width: dim(1).ok_or_else(|| bad("a video's shape"))?,
            codec: feature["info"]["video.codec"]
                .as_str()
                .unwrap_or("h264")
                .to_string(),
            stats: stats::read_channels(&stats[&key]).ok_or_else(|| bad("a video's statistics"))?,
        });
    }
    Ok(Episode {
        fps,
        task: meta["task"]
            .as_str()
            .ok_or_else(|| bad("the task"))?
            .to_string(),
        states: read_float_lists(&dir.join(DATA_FILE), "observation.state")?,
        videos,
        cameras: serde_json::from_value(meta["cameras"].clone()).map_err(|_| bad("cameras"))?,
        hand_size: serde_json::from_value(meta["hand_size"].clone())
            .map_err(|_| bad("hand_size"))?,
        source: meta["source"].as_str().map(String::from),
    })
}

/// A hidden folder beside `dir`: `.NAME.SUFFIX`.
fn beside(dir: &Path, suffix: &str) -> PathBuf {
    let name = dir
        .file_name()
        .map_or("dataset".into(), |n| n.to_string_lossy());
    dir.with_file_name(format!(".{name}.{suffix}"))
}

/// Where a dataset for `dir` is made before it is renamed to `dir`: `.NAME.monohand-partial`
/// beside it (what a killed process leaves is never a dataset).
pub fn staging_dir(dir: &Path) -> PathBuf {
    beside(dir, "monohand-partial")
}

/// What [`assemble`] made.
#[derive(Debug, Clone, PartialEq)]
pub struct Assembled {
    /// Episodes in the dataset.
    pub episodes: usize,
    /// Frames in the dataset.
    pub frames: usize,
    /// The parts left out, and why (a frame rate or frame size other than the first's).
    pub left_out: Vec<(PathBuf, String)>,
}

/// Why episode `e` cannot join a dataset whose first episode is `first`, if it cannot.
fn mismatch(first: &Episode, e: &Episode) -> Option<String> {
    let shape =
        |e: &Episode| -> Vec<(u32, u32)> { e.videos.iter().map(|v| (v.width, v.height)).collect() };
    (e.fps != first.fps || shape(e) != shape(first)).then(|| {
        format!(
            "{} fps and frames {:?} where the dataset's first episode has {} fps and {:?}: a \
             dataset's episodes share the frame rate and the frames' size",
            e.fps,
            shape(e),
            first.fps,
            shape(first)
        )
    })
}

/// One dataset at `out` of the one-episode datasets `parts`, in order: their videos linked
/// (else copied) in, the tables written anew. A part whose frame rate or frame size is not
/// the first's is left out, and said. Made beside `out` and renamed to it when whole; an
/// `out` already there (an earlier assembly) is replaced.
pub fn assemble(parts: &[PathBuf], out: &Path) -> Result<Assembled, IoError> {
    let mut taken: Vec<(&PathBuf, Episode)> = Vec::new();
    let mut left_out = Vec::new();
    for part in parts {
        let e = read_episode(part)?;
        match taken.first().and_then(|(_, first)| mismatch(first, &e)) {
            Some(why) => left_out.push((part.clone(), why)),
            None => taken.push((part, e)),
        }
    }
    if taken.is_empty() {
        return Err(format_error(out, "no episodes to make a dataset of"));
    }
    let (staging, old) = (staging_dir(out), beside(out, "monohand-old"));
    let write = |path: &Path, error| IoError::Write {
        path: path.to_path_buf(),
        error,
    };
    if staging.exists() {
        std::fs::remove_dir_all(&staging).map_err(|e| write(&staging, e))?;
    }
    for (k, (part, e)) in taken.iter().enumerate() {
        for v in 1..=e.videos.len() {
            let from = part.join(video_file(v, 0));
            let to = file_in(&staging, &video_file(v, k))?;
            if std::fs::hard_link(&from, &to).is_err() {
                std::fs::copy(&from, &to).map_err(|e| write(&to, e))?;
            }
        }
    }
    let episodes: Vec<Episode> = taken.into_iter().map(|(_, e)| e).collect();
    write_dataset(&staging, &episodes)?;
    if out.exists() {
        let _ = std::fs::remove_dir_all(&old);
        std::fs::rename(out, &old).map_err(|e| write(out, e))?;
    }
    std::fs::rename(&staging, out).map_err(|e| write(out, e))?;
    let _ = std::fs::remove_dir_all(&old);
    Ok(Assembled {
        episodes: episodes.len(),
        frames: episodes.iter().map(|e| e.states.len()).sum(),
        left_out,
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// The state's names and values line up: each hand's slot starts with its flag, the
    /// wrist joint's x is next, and the wrist pose ends the slot.
    #[test]
    fn the_state_has_a_name_per_value_in_order() {
        let names = state_names();
        assert_eq!(names.len(), STATE_LEN);
        assert_eq!(names[0], "left.valid");
        assert_eq!(names[1], "left.wrist.x_m");
        assert_eq!(names[HAND_STATE_LEN - 1], "left.wrist_pose.qw");
        assert_eq!(names[HAND_STATE_LEN], "right.valid");
        assert_eq!(names[HAND_STATE_LEN + 3 * 8 + 3], "right.index_tip.z_m");
        let mut joints = [[0.0; 3]; NUM_JOINTS];
        joints[8] = [0.1, 0.2, 0.3];
        let right = HandState {
            joints_m: joints,
            wrist_m: [0.0, 0.0, 0.5],
            wrist_quaternion_xyzw: [0.0, 0.0, 0.0, 1.0],
        };
        let s = frame_state(None, Some(&right));
        assert!(
            s[..HAND_STATE_LEN].iter().all(|v| *v == 0.0),
            "no left hand"
        );
        assert_eq!(s[HAND_STATE_LEN], 1.0);
        assert_eq!(s[HAND_STATE_LEN + 1 + 3 * 8 + 2], 0.3);
        assert_eq!(s[STATE_LEN - 1], 1.0);
        assert_eq!(s[STATE_LEN - 5], 0.5);
        assert_eq!(side_slot(HandSide::Right), 1);
        assert_eq!(
            video_file(2, 1001),
            "videos/observation.images.view2/chunk-001/file-001.mp4"
        );
    }

    fn episode(frames: usize, task: &str, value: f32) -> Episode {
        let mut m = Moments::default();
        m.add(f64::from(value));
        Episode {
            fps: 30,
            task: task.into(),
            states: vec![vec![value; STATE_LEN]; frames],
            videos: vec![VideoInfo {
                width: 4,
                height: 2,
                codec: "h264".into(),
                stats: [m.summary(frames as u64); 3],
            }],
            cameras: Vec::new(),
            hand_size: None,
            source: Some(format!("{task}.mp4")),
        }
    }

    /// An episode written and read back is the same episode; one without frames is
    /// refused and leaves no info.json.
    #[test]
    fn an_episode_reads_back_as_written() {
        let dir = tempfile::tempdir().unwrap();
        assert!(write_episode(dir.path(), &episode(0, "t", 0.0)).is_err());
        assert!(!dir.path().join("meta/info.json").exists());
        let one = episode(3, "t", 0.25);
        write_episode(dir.path(), &one).unwrap();
        assert_eq!(read_episode(dir.path()).unwrap(), one);
        let info = read_json(&dir.path().join("meta/info.json")).unwrap();
        assert_eq!(info["codebase_version"], "v3.0");
        assert_eq!(info["total_frames"], 3);
        assert_eq!(info["features"]["observation.state"]["shape"][0], STATE_LEN);
    }

    /// Parts assembled: each episode's rows in turn, its video linked in as its own file,
    /// the tasks shared, the image statistics pooled; parts of other sizes are refused;
    /// assembling again replaces the dataset.
    #[test]
    fn parts_assemble_into_one_dataset() {
        let dir = tempfile::tempdir().unwrap();
        let mut parts = Vec::new();
        for (k, (n, task, v)) in [(3, "a", 0.0), (2, "b", 1.0), (4, "a", 0.5)]
            .into_iter()
            .enumerate()
        {
            let p = dir.path().join(format!("part{k}"));
            let video = file_in(&p, &video_file(1, 0)).unwrap();
            std::fs::write(&video, format!("video {k}")).unwrap();
            write_episode(&p, &episode(n, task, v)).unwrap();
            parts.push(p);
        }
        let out = dir.path().join("all");
        let made = assemble(&parts, &out).unwrap();
        assert_eq!((made.episodes, made.frames, made.left_out.len()), (3, 9, 0));
        let info = read_json(&out.join("meta/info.json")).unwrap();
        assert_eq!(
            (
                info["total_episodes"].as_u64(),
                info["total_frames"].as_u64()
            ),
            (Some(3), Some(9))
        );
        assert_eq!(info["total_tasks"], 2);
        assert_eq!(info["monohand"]["episodes"][1]["source"], "b.mp4");
        let states = read_float_lists(&out.join(DATA_FILE), "observation.state").unwrap();
        let firsts: Vec<f32> = states.iter().map(|s| s[0]).collect();
        assert_eq!(firsts, vec![0.0, 0.0, 0.0, 1.0, 1.0, 0.5, 0.5, 0.5, 0.5]);
        for k in 0..3 {
            let text = std::fs::read_to_string(out.join(video_file(1, k))).unwrap();
            assert_eq!(text, format!("video {k}"));
        }
        let stats = read_json(&out.join("meta/stats.json")).unwrap();
        let mean = stats[video_key(1)]["mean"][0][0][0].as_f64().unwrap();
        assert!(
            (mean - (0.0 * 3.0 + 1.0 * 2.0 + 0.5 * 4.0) / 9.0).abs() < 1e-9,
            "{mean}"
        );
        assert_eq!(stats["episode_index"]["max"][0], 2.0);
        // Another frame size cannot join.
        let odd = dir.path().join("odd");
        let mut e = episode(2, "a", 0.0);
        e.videos[0].width = 8;
        std::fs::write(file_in(&odd, &video_file(1, 0)).unwrap(), "x").unwrap();
        write_episode(&odd, &e).unwrap();
        let some = assemble(&[parts[0].clone(), odd.clone()], &dir.path().join("some")).unwrap();
        assert_eq!((some.episodes, some.frames), (1, 3));
        assert_eq!(some.left_out.len(), 1);
        assert!(
            some.left_out[0].1.contains("share the frame rate"),
            "{:?}",
            some.left_out
        );
        assert!(assemble(&[], &dir.path().join("none")).is_err());
        assert!(!dir.path().join("none").exists());
        // Again, with fewer parts: replaced.
        assemble(&parts[..1], &out).unwrap();
        assert_eq!(
            read_json(&out.join("meta/info.json")).unwrap()["total_episodes"],
            1
        );
        assert!(!out.join(video_file(1, 1)).exists());
    }
}
