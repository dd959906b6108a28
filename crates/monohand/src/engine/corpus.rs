//! A folder of inputs run one by one, each into a records file of its own that is complete
//! or absent: written under a `.partial` name and renamed when its input has ended well, so
//! a rerun after a crash or a kill skips what is done and redoes the rest.

use super::overlay_paths::{has_extension, IMAGE_EXTENSIONS, VIDEO_EXTENSIONS};
use super::{
    Engine, EngineError, EngineResult, FrameSource, InputError, JsonlSink, Observer, Sink,
};
use std::path::{Path, PathBuf};

/// One input of a folder, and where its records go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CorpusItem {
    /// The video or image file.
    pub input: PathBuf,
    /// `OUT/<file name>.jsonl`: present only when complete.
    pub output: PathBuf,
    /// Where the input's LeRobot episode goes, when the job makes a dataset.
    pub episode: Option<EpisodeOutput>,
}

/// An input's LeRobot episode: a one-episode dataset `OUT/<file name>.lerobot`, whole or
/// absent, which [`monohand_io::lerobot::assemble`] joins with the others'.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EpisodeOutput {
    /// The episode's folder.
    pub dir: PathBuf,
    /// Its task's text.
    pub task: String,
}

impl CorpusItem {
    /// Whether the records of this input are complete (a rerun skips it), its episode
    /// too when one is asked for.
    pub fn is_done(&self) -> bool {
        self.output.is_file()
            && self
                .episode
                .as_ref()
                .is_none_or(|e| e.dir.join("meta/info.json").is_file())
    }

    /// The same, with a LeRobot episode of task `task` beside its records.
    pub fn with_episode(mut self, task: &str) -> CorpusItem {
        let mut name = self.input.file_name().unwrap_or_default().to_os_string();
        name.push(".lerobot");
        self.episode = Some(EpisodeOutput {
            dir: self.output.with_file_name(name),
            task: task.to_string(),
        });
        self
    }

    /// Where the records are written while the input runs (and stay if it fails half-way).
    pub fn partial(&self) -> PathBuf {
        let mut name = self.output.clone().into_os_string();
        name.push(".partial");
        PathBuf::from(name)
    }

    /// Marks the records complete: the partial file takes the output's name.
    pub fn commit(&self) -> std::io::Result<()> {
        std::fs::rename(self.partial(), &self.output)
    }

    /// Runs `source` through `engine` into the partial file and, if the input ended well,
    /// gives the records their name. An input that cannot be used or ends early is an
    /// ending ([`Ended::Failed`], its good frames kept in the partial file); what concerns
    /// the whole job (a file that cannot be written or renamed) is an error.
    pub fn run(
        &self,
        engine: &Engine,
        source: Box<dyn FrameSource>,
        observer: &dyn Observer,
    ) -> EngineResult<Ended> {
        let sources = vec![source];
        if let Err(e) = engine.check_sources(&sources) {
            return Ok(Ended::Failed(e.to_string()));
        }
        let partial = self.partial();
        // An output that cannot be made or renamed (a full disk, no permission) stops the
        // job: it is an output error, as in `run`, with what was written kept.
        let output = |what: String, e: &dyn std::fmt::Display| EngineError::Output {
            frames: 0,
            source: format!("{what}: {e}").into(),
        };
        let fps = sources[0].fps();
        let sink =
            JsonlSink::create(&partial).map_err(|e| output(partial.display().to_string(), &e))?;
        let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(sink)];
        if let Some(episode) = &self.episode {
            sinks.push(
                self.episode_sink(episode, fps)
                    .map_err(|e| output(format!("--lerobot {}", episode.dir.display()), &e))?,
            );
        }
        let report = engine.run(sources, &mut sinks, observer)?;
        drop(sinks);
        if report.cancelled {
            return Ok(Ended::Cancelled);
        }
        if let Some(e) = report.input_error {
            return Ok(Ended::Failed(format!(
                "{e} (its {} good frames are in {})",
                report.frames,
                partial.display()
            )));
        }
        if report.nothing_readable() {
            return Ok(Ended::Failed("no frame could be read".into()));
        }
        self.commit().map_err(|e| {
            let what = format!(
                "renaming {} to {}",
                partial.display(),
                self.output.display()
            );
            output(what, &e)
        })?;
        Ok(Ended::Done)
    }
}

impl CorpusItem {
    /// The sink of the input's episode (an earlier, unfinished one removed first).
    #[cfg(feature = "lerobot")]
    fn episode_sink(
        &self,
        episode: &EpisodeOutput,
        fps: Option<f64>,
    ) -> Result<Box<dyn Sink>, super::SinkError> {
        if episode.dir.exists() {
            std::fs::remove_dir_all(&episode.dir)?;
        }
        let sink = super::LeRobotSink::create(&episode.dir, 1, fps.unwrap_or(30.0), &episode.task)?
            .with_source(Some(&self.input));
        Ok(Box::new(sink))
    }

    /// Without the `lerobot` feature: refused.
    #[cfg(not(feature = "lerobot"))]
    fn episode_sink(
        &self,
        _episode: &EpisodeOutput,
        _fps: Option<f64>,
    ) -> Result<Box<dyn Sink>, super::SinkError> {
        Err("this build of monohand has no LeRobot datasets (the `lerobot` feature)".into())
    }
}

/// How one input of a folder ended ([`CorpusItem::run`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Ended {
    /// Its records are complete, under their name.
    Done,
    /// It could not be used or ended early: why.
    Failed(String),
    /// The observer cancelled the run; a rerun redoes the input.
    Cancelled,
}

/// The videos and images directly in `dir` (file-name order; other files are left alone),
/// each with its output in `out_dir` (created).
pub fn corpus(dir: &Path, out_dir: &Path) -> EngineResult<Vec<CorpusItem>> {
    let io = |what: &Path, source: std::io::Error| InputError::Io {
        path: what.into(),
        source,
    };
    let mut inputs: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && (has_extension(p, VIDEO_EXTENSIONS) || has_extension(p, IMAGE_EXTENSIONS))
        })
        .collect();
    if inputs.is_empty() {
        return Err(InputError::EmptyFolder {
            path: dir.into(),
            what: format!(
                "videos ({}) or images ({}) in this folder",
                VIDEO_EXTENSIONS.join(", "),
                IMAGE_EXTENSIONS.join(", ")
            ),
        }
        .into());
    }
    inputs.sort();
    std::fs::create_dir_all(out_dir).map_err(|e| io(out_dir, e))?;
    Ok(inputs
        .into_iter()
        .filter_map(|input| {
            let mut name = input.file_name()?.to_os_string();
            name.push(".jsonl");
            let output = out_dir.join(name);
            Some(CorpusItem {
                input,
                output,
                episode: None,
            })
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_gives_its_videos_and_images_in_order_and_done_means_renamed() {
        let dir = tempfile::tempdir().expect("tempdir");
        for f in ["b.mp4", "a.png", "notes.txt", "c.MKV"] {
            std::fs::write(dir.path().join(f), b"x").expect("write");
        }
        std::fs::create_dir(dir.path().join("sub.mp4")).expect("dir");
        let out = dir.path().join("out");
        let items = corpus(dir.path(), &out).expect("corpus");
        let names: Vec<_> = items
            .iter()
            .map(|i| {
                i.output
                    .file_name()
                    .expect("name")
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        assert_eq!(names, ["a.png.jsonl", "b.mp4.jsonl", "c.MKV.jsonl"]);
        let item = &items[0];
        assert!(!item.is_done());
        std::fs::write(item.partial(), b"{}\n").expect("partial");
        assert!(!item.is_done(), "a partial file is not done");
        item.commit().expect("rename");
        assert!(item.is_done() && !item.partial().exists());
        let empty = tempfile::tempdir().expect("tempdir");
        assert!(corpus(empty.path(), &out).is_err());
    }
}
