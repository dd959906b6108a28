//! A LeRobot v3 dataset of the run (`monohand run --lerobot DIR`): one episode, the hands'
//! state per frame, each view's frames as a video ([`monohand_io::lerobot`]).
//!
//! The dataset is made in a folder beside `DIR` and renamed to `DIR` once whole, at the
//! end of the run (a stopped run's end included): `DIR` is either a whole dataset up to
//! the last frame written, or absent.

use super::{Output, Sink, SinkError};
use monohand_core::wrist::{wrist_pose, WristConvention};
use monohand_io::jsonl::{CameraRecord, HandSizeRecord};
use monohand_io::lerobot::{
    frame_state, side_slot, staging_dir, video_file, write_episode, Episode, HandState, Moments,
    VideoInfo,
};
use monohand_media::video::{Encoder, FfmpegTools, VideoWriter};
use monohand_vision::RgbImage;
use nalgebra::UnitQuaternion;
use std::path::{Path, PathBuf};

/// Every how many pixels, across and down, the images' statistics look.
const STATS_STRIDE: usize = 8;

/// One view's encoder, started at its first frame.
struct View {
    writer: Option<VideoWriter>,
    size: (u32, u32),
    stats: [Moments; 3],
    /// The last frame written (repeated where a frame could not be read).
    last: Option<RgbImage>,
    /// Frames before the view's first image (a view that started late): written black
    /// once its first image gives the size, so that the video has a frame per row.
    before_first: usize,
}

/// Writes the run as a LeRobot v3 dataset.
pub struct LeRobotSink {
    dir: PathBuf,
    staging: PathBuf,
    fps: u32,
    task: String,
    encoder: Encoder,
    tools: FfmpegTools,
    views: Vec<View>,
    states: Vec<Vec<f32>>,
    cameras: Vec<CameraRecord>,
    hand_size: Option<HandSizeRecord>,
    source: Option<String>,
}

impl std::fmt::Debug for LeRobotSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LeRobotSink")
            .field("dir", &self.dir)
            .finish()
    }
}

impl LeRobotSink {
    /// A dataset at `dir` (which must not hold anything yet) of `views` views at `fps`
    /// (LeRobot's are whole numbers: rounded), its one task described by `task`.
    pub fn create(
        dir: &Path,
        views: usize,
        fps: f64,
        task: &str,
    ) -> Result<LeRobotSink, SinkError> {
        if dir.is_file() {
            return Err(format!(
                "{}: is a file; give a folder for the dataset",
                dir.display()
            )
            .into());
        }
        if std::fs::read_dir(dir).is_ok_and(|mut d| d.next().is_some()) {
            return Err(format!(
                "{}: already holds files; give a new folder (one dataset per run)",
                dir.display()
            )
            .into());
        }
        let staging = staging_dir(dir);
        if staging.exists() {
            // What a killed run left: never a dataset.
            std::fs::remove_dir_all(&staging).map_err(|e| format!("{}: {e}", staging.display()))?;
        }
        std::fs::create_dir_all(&staging).map_err(|e| format!("{}: {e}", staging.display()))?;
        let tools = FfmpegTools::default();
        let fps = if fps.is_finite() && fps >= 1.0 {
            fps.round() as u32
        } else {
            30
        };
        Ok(LeRobotSink {
            dir: dir.to_path_buf(),
            staging,
            fps,
            task: task.to_string(),
            encoder: Encoder::best_available(&tools),
            tools,
            views: (0..views.max(1))
                .map(|_| View {
                    writer: None,
                    size: (0, 0),
                    stats: [Moments::default(); 3],
                    last: None,
                    before_first: 0,
                })
                .collect(),
            states: Vec::new(),
            cameras: Vec::new(),
            hand_size: None,
            source: None,
        })
    }

    /// Names what the episode is made from in `info.json`: the file name of `input` (the
    /// path of a video, or of the first view's), if it has one.
    pub fn with_source(mut self, input: Option<&std::path::Path>) -> LeRobotSink {
        self.source = input
            .and_then(std::path::Path::file_name)
            .map(|n| n.to_string_lossy().into_owned());
        self
    }

    /// The frame's state: the first fitted hand of each side.
    fn state(frame: &Output<'_>) -> Vec<f32> {
        let mut sides: [Option<HandState>; 2] = [None, None];
        for hand in frame.fitted.map_or(&[][..], |f| &f.hands[..]) {
            let Some(fit) = &hand.fit else { continue };
            let slot = &mut sides[side_slot(hand.side)];
            if slot.is_some() {
                continue;
            }
            let Some(w) = wrist_pose(&fit.pose, &fit.joints_3d, WristConvention::Mano) else {
                continue;
            };
            let q = UnitQuaternion::from_rotation_matrix(&w.rotation);
            *slot = Some(HandState {
                joints_m: fit
                    .joints_3d
                    .map(|p| [p.x / 1000.0, p.y / 1000.0, p.z / 1000.0]),
                wrist_m: [
                    w.position_mm.x / 1000.0,
                    w.position_mm.y / 1000.0,
                    w.position_mm.z / 1000.0,
                ],
                wrist_quaternion_xyzw: [q.i, q.j, q.k, q.w],
            });
        }
        frame_state(sides[0].as_ref(), sides[1].as_ref())
    }

    /// View `v`'s next frame: `image`, or its last frame again where this one could not
    /// be read (black before its first frame).
    fn write_view(&mut self, v: usize, image: Option<&RgbImage>) -> Result<(), SinkError> {
        match image {
            Some(i) => {
                let before = std::mem::take(&mut self.views[v].before_first);
                if before > 0 {
                    let black = RgbImage::new(i.width(), i.height());
                    for _ in 0..before {
                        self.encode(v, &black)?;
                    }
                }
                self.encode(v, i)?;
                let view = &mut self.views[v];
                match &mut view.last {
                    Some(last) if last.dimensions() == i.dimensions() => last.copy_from_slice(i),
                    _ => view.last = Some(i.clone()),
                }
                Ok(())
            }
            None => match self.views[v].last.take() {
                Some(last) => {
                    let done = self.encode(v, &last);
                    self.views[v].last = Some(last);
                    done
                }
                None => {
                    self.views[v].before_first += 1;
                    Ok(())
                }
            },
        }
    }

    /// Encodes one frame of view `v` (its video started at its first) and adds it to the
    /// view's statistics.
    fn encode(&mut self, v: usize, image: &RgbImage) -> Result<(), SinkError> {
        let view = &mut self.views[v];
        if view.writer.is_none() {
            let path = self.staging.join(video_file(v + 1, 0));
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent)
                    .map_err(|e| format!("{}: {e}", parent.display()))?;
            }
            view.writer = Some(VideoWriter::create_with(
                &self.tools,
                self.encoder,
                &path,
                image.width() as usize,
                image.height() as usize,
                f64::from(self.fps),
            )?);
            view.size = image.dimensions();
        }
        if image.dimensions() != view.size {
            return Err(format!(
                "view {}: a frame of {}x{} in a video of {}x{}",
                v + 1,
                image.width(),
                image.height(),
                view.size.0,
                view.size.1
            )
            .into());
        }
        for y in (0..image.height()).step_by(STATS_STRIDE) {
            for x in (0..image.width()).step_by(STATS_STRIDE) {
                for (m, c) in view.stats.iter_mut().zip(image.get_pixel(x, y).0) {
                    m.add(f64::from(c) / 255.0);
                }
            }
        }
        if let Some(w) = view.writer.as_mut() {
            w.write(image)?;
        }
        Ok(())
    }
}

impl Sink for LeRobotSink {
    fn wants_images(&self) -> bool {
        true
    }

    fn wants_every_view(&self) -> bool {
        self.views.len() > 1
    }

    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError> {
        self.write_view(0, frame.image)?;
        for v in 1..self.views.len() {
            let image = frame.other_images.get(v - 1).and_then(Option::as_ref);
            self.write_view(v, image)?;
        }
        self.states.push(LeRobotSink::state(frame));
        if !frame.record.cameras.is_empty() {
            self.cameras.clone_from(&frame.record.cameras);
        }
        if let Some(size) = frame.fitted.and_then(|f| f.hand_size.as_ref()) {
            self.hand_size = Some(size.clone());
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<(), SinkError> {
        let frames = self.states.len() as u64;
        let mut videos = Vec::new();
        for view in &mut self.views {
            if let Some(w) = view.writer.take() {
                w.finish()?;
                videos.push(VideoInfo {
                    width: view.size.0,
                    height: view.size.1,
                    codec: match self.encoder {
                        Encoder::Libx264 => "h264",
                        Encoder::Mpeg4 => "mpeg4",
                    }
                    .into(),
                    stats: view.stats.map(|m| m.summary(frames)),
                });
            }
        }
        if self.states.is_empty() {
            let _ = std::fs::remove_dir_all(&self.staging);
            return Err(format!("{}: no frames, so no dataset", self.dir.display()).into());
        }
        if videos.len() != self.views.len() {
            let _ = std::fs::remove_dir_all(&self.staging);
            return Err(format!(
                "{}: a view without a single readable frame, so no dataset",
                self.dir.display()
            )
            .into());
        }
        let episode = Episode {
            fps: self.fps,
            task: self.task.clone(),
            states: std::mem::take(&mut self.states),
            videos,
            cameras: std::mem::take(&mut self.cameras),
            hand_size: self.hand_size.take(),
            source: self.source.clone(),
        };
        write_episode(&self.staging, &episode)?;
        if self.dir.is_dir() {
            // Checked empty when the run started.
            std::fs::remove_dir(&self.dir).map_err(|e| format!("{}: {e}", self.dir.display()))?;
        }
        std::fs::rename(&self.staging, &self.dir)
            .map_err(|e| format!("{}: {e}", self.dir.display()).into())
    }
}
