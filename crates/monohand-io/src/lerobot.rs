//! LeRobot v3 datasets of tracked hands (`monohand run --lerobot DIR`): the layout, the
//! state vector and the tables, as LeRobot's `LeRobotDataset` (codebase `v3.0`) reads them.
//!
//! ```text
//! DIR/meta/info.json                         fps, features, path templates, the cameras ("monohand")
//! DIR/meta/stats.json                        per feature: min, max, mean, std, count
//! DIR/meta/tasks.parquet                     the task's text and its index
//! DIR/meta/episodes/chunk-000/file-000.parquet   the episode: length, rows, video span
//! DIR/data/chunk-000/file-000.parquet        a row per frame: observation.state, action, ...
//! DIR/videos/observation.images.view1/chunk-000/file-000.mp4   the frames (the caller encodes them)
//! ```
//!
//! The state ([`state_names`]) is both hands, left then right, each `valid` (1 when the hand
//! was fitted in 3D, else 0 and the hand's values 0), its 21 joints in metres in the first
//! camera's frame (in [`JOINT_NAMES`] order) and its wrist pose (position in metres and
//! orientation as a quaternion `x, y, z, w`, MANO's wrist frame:
//! [`monohand_core::wrist`]). `action` is the next frame's state (the last frame's own).
//! This module writes plain data; which hand goes where is the caller's.

use crate::error::IoError;
use crate::jsonl::{CameraRecord, HandSizeRecord};
use monohand_core::hand_model::{HandSide, JOINT_NAMES, NUM_JOINTS};
use parquet::basic::{LogicalType, Repetition, Type as PhysicalType};
use parquet::data_type::{ByteArray, ByteArrayType, DoubleType, FloatType, Int64Type};
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::format::KeyValue;
use parquet::schema::types::Type;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The LeRobot dataset format written (`info.json`'s `codebase_version`).
pub const CODEBASE_VERSION: &str = "v3.0";
/// `info.json`'s `robot_type`: a human hand seen by cameras.
pub const ROBOT_TYPE: &str = "human_hand";
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

/// Where view `view`'s video goes, relative to the dataset.
pub fn video_file(view: usize) -> String {
    format!("videos/{}/chunk-000/file-000.mp4", video_key(view))
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

/// One view's video, as encoded by the caller.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoInfo {
    /// Frame width and height, pixels.
    pub width: u32,
    /// Frame height, pixels.
    pub height: u32,
    /// The codec's name as LeRobot states it (`h264`, `mpeg4`).
    pub codec: String,
    /// Per channel (R, G, B), the pixels' statistics in `[0, 1]`.
    pub stats: [Moments; 3],
}

/// Running statistics of one value: what `stats.json` holds per entry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moments {
    /// Smallest value seen.
    pub min: f64,
    /// Largest value seen.
    pub max: f64,
    /// Values seen.
    pub count: u64,
    sum: f64,
    sum_sq: f64,
}

impl Default for Moments {
    fn default() -> Moments {
        Moments {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            count: 0,
            sum: 0.0,
            sum_sq: 0.0,
        }
    }
}

impl Moments {
    /// Adds a value.
    pub fn add(&mut self, v: f64) {
        self.min = self.min.min(v);
        self.max = self.max.max(v);
        self.count += 1;
        self.sum += v;
        self.sum_sq += v * v;
    }

    /// The mean (0 when empty).
    pub fn mean(&self) -> f64 {
        if self.count == 0 {
            return 0.0;
        }
        self.sum / self.count as f64
    }

    /// The population standard deviation (0 when empty).
    pub fn std(&self) -> f64 {
        if self.count == 0 {
            return 0.0;
        }
        (self.sum_sq / self.count as f64 - self.mean().powi(2))
            .max(0.0)
            .sqrt()
    }

    fn finite(v: f64) -> f64 {
        if v.is_finite() {
            v
        } else {
            0.0
        }
    }
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
    /// The camera of each view, as the last frame was fitted with (the intrinsics of
    /// `info.json`'s `"monohand"` key).
    pub cameras: Vec<CameraRecord>,
    /// The hand size the fit used, if it said.
    pub hand_size: Option<HandSizeRecord>,
}

/// A parquet column: its name and values, one per row.
enum Column<'a> {
    FloatList(&'a [Vec<f32>]),
    Float(Vec<f32>),
    Double(Vec<f64>),
    Int(Vec<i64>),
    Text(Vec<String>),
    TextList(Vec<Vec<String>>),
}

impl Column<'_> {
    fn field(&self, name: &str) -> parquet::errors::Result<Type> {
        let leaf = |name: &str, physical, logical: Option<LogicalType>| {
            Type::primitive_type_builder(name, physical)
                .with_repetition(Repetition::REQUIRED)
                .with_logical_type(logical)
                .build()
        };
        let list = |element: Type| -> parquet::errors::Result<Type> {
            let repeated = Type::group_type_builder("list")
                .with_repetition(Repetition::REPEATED)
                .with_fields(vec![Arc::new(element)])
                .build()?;
            Type::group_type_builder(name)
                .with_repetition(Repetition::REQUIRED)
                .with_logical_type(Some(LogicalType::List))
                .with_fields(vec![Arc::new(repeated)])
                .build()
        };
        match self {
            Column::FloatList(_) => list(leaf("element", PhysicalType::FLOAT, None)?),
            Column::Float(_) => leaf(name, PhysicalType::FLOAT, None),
            Column::Double(_) => leaf(name, PhysicalType::DOUBLE, None),
            Column::Int(_) => leaf(name, PhysicalType::INT64, None),
            Column::Text(_) => leaf(name, PhysicalType::BYTE_ARRAY, Some(LogicalType::String)),
            Column::TextList(_) => list(leaf(
                "element",
                PhysicalType::BYTE_ARRAY,
                Some(LogicalType::String),
            )?),
        }
    }
}

/// The definition and repetition levels of a list column of these lengths (the outer list
/// required, its elements required: level 1 for a value, 0 for an empty list).
fn list_levels(lengths: impl Iterator<Item = usize>) -> (Vec<i16>, Vec<i16>) {
    let (mut def, mut rep) = (Vec::new(), Vec::new());
    for n in lengths {
        if n == 0 {
            def.push(0);
            rep.push(0);
        }
        for k in 0..n {
            def.push(1);
            rep.push(i16::from(k > 0));
        }
    }
    (def, rep)
}

fn text(values: impl IntoIterator<Item = String>) -> Vec<ByteArray> {
    values
        .into_iter()
        .map(|s| ByteArray::from(s.into_bytes()))
        .collect()
}

/// Writes one row group of `columns` to `path` (uncompressed), with `metadata` key-value
/// pairs in the footer.
fn write_table<S: AsRef<str>>(
    path: &Path,
    columns: &[(S, Column<'_>)],
    metadata: Vec<KeyValue>,
) -> Result<(), IoError> {
    let bad = |e: parquet::errors::ParquetError| IoError::Format {
        file: path.display().to_string(),
        message: format!("cannot write parquet: {e}"),
    };
    let fields = columns
        .iter()
        .map(|(name, c)| c.field(name.as_ref()).map(Arc::new))
        .collect::<Result<Vec<_>, _>>()
        .map_err(bad)?;
    let schema = Type::group_type_builder("schema")
        .with_fields(fields)
        .build()
        .map_err(bad)?;
    let props = WriterProperties::builder()
        .set_key_value_metadata((!metadata.is_empty()).then_some(metadata))
        .set_created_by(format!("monohand {}", env!("CARGO_PKG_VERSION")))
        .build();
    let file = std::fs::File::create(path).map_err(|error| IoError::Write {
        path: path.to_path_buf(),
        error,
    })?;
    let mut writer =
        SerializedFileWriter::new(file, Arc::new(schema), Arc::new(props)).map_err(bad)?;
    let mut group = writer.next_row_group().map_err(bad)?;
    for (_, column) in columns {
        let Some(mut col) = group.next_column().map_err(bad)? else {
            break;
        };
        match column {
            Column::FloatList(rows) => {
                let values: Vec<f32> = rows.iter().flatten().copied().collect();
                let (def, rep) = list_levels(rows.iter().map(Vec::len));
                col.typed::<FloatType>()
                    .write_batch(&values, Some(&def), Some(&rep))
            }
            Column::Float(v) => col.typed::<FloatType>().write_batch(v, None, None),
            Column::Double(v) => col.typed::<DoubleType>().write_batch(v, None, None),
            Column::Int(v) => col.typed::<Int64Type>().write_batch(v, None, None),
            Column::Text(v) => {
                col.typed::<ByteArrayType>()
                    .write_batch(&text(v.iter().cloned()), None, None)
            }
            Column::TextList(rows) => {
                let (def, rep) = list_levels(rows.iter().map(Vec::len));
                let values = text(rows.iter().flatten().cloned());
                col.typed::<ByteArrayType>()
                    .write_batch(&values, Some(&def), Some(&rep))
            }
        }
        .map_err(bad)?;
        col.close().map_err(bad)?;
    }
    group.close().map_err(bad)?;
    writer.close().map_err(bad)?;
    Ok(())
}

/// `stats.json`'s entry of values seen one by one (`shape (1,)`).
fn scalar_stats(values: impl Iterator<Item = f64>) -> Value {
    let mut m = Moments::default();
    values.for_each(|v| m.add(v));
    json!({
        "min": [Moments::finite(m.min)], "max": [Moments::finite(m.max)],
        "mean": [m.mean()], "std": [m.std()], "count": [m.count],
    })
}

/// `stats.json`'s entry of a vector feature, value by value.
fn vector_stats(rows: &[Vec<f32>]) -> Value {
    let width = rows.first().map_or(0, Vec::len);
    let mut m = vec![Moments::default(); width];
    for row in rows {
        for (mi, v) in m.iter_mut().zip(row) {
            mi.add(f64::from(*v));
        }
    }
    json!({
        "min": m.iter().map(|x| Moments::finite(x.min)).collect::<Vec<_>>(),
        "max": m.iter().map(|x| Moments::finite(x.max)).collect::<Vec<_>>(),
        "mean": m.iter().map(Moments::mean).collect::<Vec<_>>(),
        "std": m.iter().map(Moments::std).collect::<Vec<_>>(),
        "count": [rows.len()],
    })
}

/// An image feature's entry: per channel, shape `(3, 1, 1)`, values in `[0, 1]`.
fn image_stats(video: &VideoInfo, frames: usize) -> Value {
    let per = |f: &dyn Fn(&Moments) -> f64| -> Value {
        video.stats.iter().map(|m| json!([[f(m)]])).collect()
    };
    json!({
        "min": per(&|m| Moments::finite(m.min)), "max": per(&|m| Moments::finite(m.max)),
        "mean": per(&Moments::mean), "std": per(&Moments::std), "count": [frames],
    })
}

/// pandas' footer metadata of a table whose index is the column `index` (text): what
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

fn write_json(path: &Path, value: &Value) -> Result<(), IoError> {
    let text = serde_json::to_string_pretty(value).unwrap_or_default() + "\n";
    std::fs::write(path, text).map_err(|error| IoError::Write {
        path: path.to_path_buf(),
        error,
    })
}

fn create_dir(path: &Path) -> Result<(), IoError> {
    std::fs::create_dir_all(path).map_err(|error| IoError::Write {
        path: path.to_path_buf(),
        error,
    })
}

/// Writes the tables and the metadata of a one-episode dataset into `dir`, whose videos
/// are already at [`video_file`]; `meta/info.json` last, so that a folder without it was
/// not finished. Refuses an episode without frames.
pub fn write_episode(dir: &Path, episode: &Episode) -> Result<(), IoError> {
    let n = episode.states.len();
    if n == 0 || episode.fps == 0 {
        return Err(IoError::Format {
            file: dir.display().to_string(),
            message: "a LeRobot episode needs at least one frame and a frame rate".into(),
        });
    }
    let file = |rel: &str| -> Result<PathBuf, IoError> {
        let p = dir.join(rel);
        if let Some(parent) = p.parent() {
            create_dir(parent)?;
        }
        Ok(p)
    };
    let fps = f64::from(episode.fps);
    let actions: Vec<Vec<f32>> = (0..n)
        .map(|i| episode.states[(i + 1).min(n - 1)].clone())
        .collect();
    let frames: Vec<i64> = (0..n as i64).collect();
    let times: Vec<f32> = (0..n).map(|i| (i as f64 / fps) as f32).collect();
    write_table(
        &file(DATA_FILE)?,
        &[
            ("observation.state", Column::FloatList(&episode.states)),
            ("action", Column::FloatList(&actions)),
            ("timestamp", Column::Float(times.clone())),
            ("frame_index", Column::Int(frames.clone())),
            ("episode_index", Column::Int(vec![0; n])),
            ("index", Column::Int(frames.clone())),
            ("task_index", Column::Int(vec![0; n])),
        ],
        Vec::new(),
    )?;
    let span_s = n as f64 / fps;
    let mut columns: Vec<(String, Column<'_>)> = vec![
        ("episode_index".into(), Column::Int(vec![0])),
        (
            "tasks".into(),
            Column::TextList(vec![vec![episode.task.clone()]]),
        ),
        ("length".into(), Column::Int(vec![n as i64])),
        ("data/chunk_index".into(), Column::Int(vec![0])),
        ("data/file_index".into(), Column::Int(vec![0])),
        ("dataset_from_index".into(), Column::Int(vec![0])),
        ("dataset_to_index".into(), Column::Int(vec![n as i64])),
    ];
    for v in 1..=episode.videos.len() {
        let key = video_key(v);
        columns.push((format!("videos/{key}/chunk_index"), Column::Int(vec![0])));
        columns.push((format!("videos/{key}/file_index"), Column::Int(vec![0])));
        columns.push((
            format!("videos/{key}/from_timestamp"),
            Column::Double(vec![0.0]),
        ));
        columns.push((
            format!("videos/{key}/to_timestamp"),
            Column::Double(vec![span_s]),
        ));
    }
    columns.push(("meta/episodes/chunk_index".into(), Column::Int(vec![0])));
    columns.push(("meta/episodes/file_index".into(), Column::Int(vec![0])));
    write_table(&file(EPISODES_FILE)?, &columns, Vec::new())?;
    write_table(
        &file("meta/tasks.parquet")?,
        &[
            ("task_index", Column::Int(vec![0])),
            ("task", Column::Text(vec![episode.task.clone()])),
        ],
        vec![pandas_index_metadata("task", "task_index")],
    )?;

    let mut stats = serde_json::Map::new();
    stats.insert("observation.state".into(), vector_stats(&episode.states));
    stats.insert("action".into(), vector_stats(&actions));
    stats.insert(
        "timestamp".into(),
        scalar_stats(times.iter().map(|t| f64::from(*t))),
    );
    for key in ["frame_index", "index"] {
        stats.insert(key.into(), scalar_stats(frames.iter().map(|f| *f as f64)));
    }
    for key in ["episode_index", "task_index"] {
        stats.insert(key.into(), scalar_stats((0..n).map(|_| 0.0)));
    }
    for (v, video) in episode.videos.iter().enumerate() {
        stats.insert(video_key(v + 1), image_stats(video, n));
    }
    write_json(&file("meta/stats.json")?, &Value::Object(stats))?;
    write_json(&file("meta/info.json")?, &info(episode, n))
}

/// `meta/info.json`.
fn info(episode: &Episode, frames: usize) -> Value {
    let names = state_names();
    let scalar = |dtype: &str| json!({"dtype": dtype, "shape": [1], "names": null});
    let mut features = serde_json::Map::new();
    features.insert(
        "observation.state".into(),
        json!({"dtype": "float32", "shape": [STATE_LEN], "names": names}),
    );
    features.insert(
        "action".into(),
        json!({"dtype": "float32", "shape": [STATE_LEN], "names": names}),
    );
    for (v, video) in episode.videos.iter().enumerate() {
        features.insert(
            video_key(v + 1),
            json!({
                "dtype": "video",
                "shape": [video.height, video.width, 3],
                "names": ["height", "width", "channels"],
                "info": {
                    "video.height": video.height, "video.width": video.width,
                    "video.codec": video.codec, "video.pix_fmt": "yuv420p",
                    "video.is_depth_map": false, "video.fps": episode.fps,
                    "video.channels": 3, "has_audio": false,
                },
            }),
        );
    }
    features.insert("timestamp".into(), scalar("float32"));
    for key in ["frame_index", "episode_index", "index", "task_index"] {
        features.insert(key.into(), scalar("int64"));
    }
    json!({
        "codebase_version": CODEBASE_VERSION,
        "robot_type": ROBOT_TYPE,
        "total_episodes": 1,
        "total_frames": frames,
        "total_tasks": 1,
        "chunks_size": 1000,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 200,
        "fps": episode.fps,
        "splits": {"train": "0:1"},
        "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
        "video_path": if episode.videos.is_empty() { Value::Null } else {
            json!("videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4")
        },
        "features": features,
        "monohand": {
            "version": env!("CARGO_PKG_VERSION"),
            "state": "both hands, left then right: valid, the 21 joints' x, y, z (metres, the \
                      first camera's frame: x right, y down, z forward), the wrist pose's x, y, z \
                      (metres) and quaternion qx, qy, qz, qw (MANO's wrist frame); action: the \
                      next frame's state",
            "cameras": episode.cameras,
            "hand_size": episode.hand_size,
        },
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
    }

    /// Levels of a list column: a value each, the first of a row at repetition 0; an
    /// empty list one level-0 entry.
    #[test]
    fn list_levels_mark_each_row_start() {
        let (def, rep) = list_levels([2, 0, 1].into_iter());
        assert_eq!(def, vec![1, 1, 0, 1]);
        assert_eq!(rep, vec![0, 1, 0, 0]);
    }

    /// The running statistics of a few values, and an empty one.
    #[test]
    fn moments_give_the_mean_and_std() {
        let mut m = Moments::default();
        for v in [1.0, 2.0, 3.0, 4.0] {
            m.add(v);
        }
        assert_eq!((m.min, m.max, m.count), (1.0, 4.0, 4));
        assert!((m.mean() - 2.5).abs() < 1e-12);
        assert!((m.std() - 1.25f64.sqrt()).abs() < 1e-12);
        assert_eq!(Moments::default().std(), 0.0);
    }

    /// An episode is written with every file of the layout, info.json last; one without
    /// frames is refused and leaves nothing.
    #[test]
    fn an_episode_writes_the_v3_layout() {
        let dir = tempfile::tempdir().unwrap();
        let none = Episode {
            fps: 30,
            task: "t".into(),
            states: Vec::new(),
            videos: Vec::new(),
            cameras: Vec::new(),
            hand_size: None,
        };
        assert!(write_episode(dir.path(), &none).is_err());
        assert!(!dir.path().join("meta").exists());
        let one = Episode {
            states: vec![frame_state(None, None); 3],
            ..none
        };
        write_episode(dir.path(), &one).unwrap();
        for f in [
            DATA_FILE,
            EPISODES_FILE,
            "meta/tasks.parquet",
            "meta/stats.json",
        ] {
            let bytes = std::fs::read(dir.path().join(f)).unwrap();
            if f.ends_with(".parquet") {
                assert_eq!(&bytes[..4], b"PAR1", "{f}");
                assert_eq!(&bytes[bytes.len() - 4..], b"PAR1", "{f}");
            }
        }
        let info: Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join("meta/info.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(info["codebase_version"], "v3.0");
        assert_eq!(info["total_frames"], 3);
        assert_eq!(info["features"]["observation.state"]["shape"][0], STATE_LEN);
        assert_eq!(info["video_path"], Value::Null);
    }
}
