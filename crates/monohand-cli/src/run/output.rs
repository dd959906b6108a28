//! Where `monohand run` writes: the poses (JSON Lines, CSV or OpenPose JSON), overlays
//! (video or PNG folder) and the animated glTF.

use super::RunArgs;
use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use monohand_core::prelude::*;
use monohand_io::export::{write_openpose_frame, CsvWriter, GltfHand, GltfWriter};
use monohand_io::jsonl::{FrameRecord, JsonlWriter};
use monohand_media::scene::{Layers, SceneRenderer};
use monohand_media::video::VideoWriter;
use monohand_vision::RgbImage;
use std::path::{Path, PathBuf};

/// Format of the poses file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum OutputFormat {
    /// JSON Lines, one record per frame (docs/output-format.md).
    Jsonl,
    /// CSV, one row per hand per frame, with a header.
    Csv,
    /// OpenPose JSON, one `{stem}_{frame:012}_keypoints.json` per frame in the --output
    /// folder, with `hand_*_keypoints_2d` and `hand_*_keypoints_3d`.
    Openpose,
}

/// How the glTF draws each hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum GltfStyle {
    /// A real hand mesh (the WebXR generic hand) skinned to the fitted joints.
    Skinned,
    /// The 21 joints and 20 bones as small solids.
    Joints,
}

/// The poses file(s).
enum Poses {
    Jsonl(JsonlWriter),
    Csv(CsvWriter),
    OpenPose { dir: PathBuf, stem: String },
}

/// Where overlays go.
enum Overlay {
    /// Encoded on the fly (started at the first frame, when the size is known).
    Video {
        path: PathBuf,
        fps: f64,
        /// The encoder and its frame size.
        writer: Option<(VideoWriter, usize, usize)>,
    },
    /// `frame_000123.png` files.
    Folder(PathBuf),
    /// One image file (PNG or JPEG), for an input of one image.
    Image(PathBuf),
}

/// All outputs of a run.
pub(crate) struct Outputs {
    poses: Poses,
    overlay: Option<Overlay>,
    gltf: Option<GltfWriter>,
    /// The cameras of every view (none: a generic camera per frame size).
    cameras: Vec<Camera>,
    layers: Layers,
    renderer: SceneRenderer,
    /// The live window (`--show`).
    show: Option<super::show::Show>,
    /// The input is one image: the window keeps it on screen at the end.
    single_image: bool,
    /// The last frame shown, for that.
    last_shown: Option<(RgbImage, FrameRecord)>,
    /// Frames written to every output.
    frames: u64,
}

/// Overlay paths with one of these extensions are videos; others are folders.
const VIDEO_EXTENSIONS: &[&str] = &["mp4", "mkv", "avi", "mov", "webm"];

/// Overlay paths with one of these extensions are one image file (one input image only).
const IMAGE_EXTENSIONS: &[&str] = &["png", "jpg", "jpeg"];

impl Outputs {
    /// Opens every output (nothing is created if an argument is wrong).
    /// `single_image`: the input is one image (the only case an image-file overlay takes).
    pub fn create(
        args: &RunArgs,
        fps: Option<f64>,
        cameras: &[Camera],
        single_image: bool,
    ) -> Result<Outputs> {
        let show = match args.show {
            true => Some(super::show::Show::new(Layers::only(&args.layers))?),
            false => None,
        };
        let overlay = match &args.overlay {
            None => None,
            Some(p) if has_extension(p, IMAGE_EXTENSIONS) => {
                if !single_image {
                    bail!(
                        "--overlay {}: an image file holds one frame, and the input has more; give \
                         a folder (one PNG per frame) or a video name ({})",
                        p.display(),
                        VIDEO_EXTENSIONS.join(", ")
                    );
                }
                Some(Overlay::Image(p.clone()))
            }
            Some(p) if is_video_path(p) => Some(Overlay::Video {
                path: p.clone(),
                fps: fps.unwrap_or(30.0),
                writer: None,
            }),
            Some(p) => {
                if p.exists() && !p.is_dir() {
                    bail!(
                        "--overlay {}: not a folder, and not a video name ({})",
                        p.display(),
                        VIDEO_EXTENSIONS.join(", ")
                    );
                }
                std::fs::create_dir_all(p).with_context(|| {
                    format!("--overlay {}: cannot create the folder", p.display())
                })?;
                Some(Overlay::Folder(p.clone()))
            }
        };
        let stdout = args.output.as_os_str() == "-";
        let poses = match args.format {
            OutputFormat::Jsonl if stdout => Poses::Jsonl(JsonlWriter::stdout()),
            OutputFormat::Jsonl => Poses::Jsonl(JsonlWriter::create(&args.output)?),
            OutputFormat::Csv if stdout => {
                Poses::Csv(CsvWriter::new(Box::new(std::io::stdout()), "<stdout>")?)
            }
            OutputFormat::Csv => Poses::Csv(CsvWriter::create(&args.output)?),
            OutputFormat::Openpose => {
                if stdout {
                    bail!("--format openpose writes one file per frame: give a folder as --output");
                }
                std::fs::create_dir_all(&args.output).with_context(|| {
                    format!(
                        "--output {}: cannot create the folder",
                        args.output.display()
                    )
                })?;
                let stem = args
                    .input
                    .as_deref()
                    .or(args.views.first().map(String::as_str))
                    .and_then(|i| Path::new(i).file_stem())
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "monohand".into());
                Poses::OpenPose {
                    dir: args.output.clone(),
                    stem,
                }
            }
        };
        let gltf = match &args.gltf {
            None => None,
            Some(p) => {
                let mut g = GltfWriter::new(p);
                if let Some(c) = cameras.first() {
                    g.set_camera_from(c);
                }
                g.set_hand(match args.gltf_hand {
                    GltfStyle::Skinned => GltfHand::Skinned,
                    GltfStyle::Joints => GltfHand::Joints,
                })?;
                Some(g)
            }
        };
        Ok(Outputs {
            poses,
            overlay,
            gltf,
            cameras: cameras.to_vec(),
            layers: Layers::only(&args.layers),
            renderer: SceneRenderer::default(),
            show,
            single_image,
            last_shown: None,
            frames: 0,
        })
    }

    /// Frames written to every output so far.
    pub fn frames_written(&self) -> u64 {
        self.frames
    }

    /// Whether the frames' pixels are needed (overlays).
    pub fn wants_images(&self) -> bool {
        self.overlay.is_some() || self.show.is_some()
    }

    /// Writes one frame's results (and its overlay, from `image`).
    pub fn write(&mut self, record: &FrameRecord, image: Option<RgbImage>) -> Result<()> {
        match &mut self.poses {
            Poses::Jsonl(w) => w.write_frame(record)?,
            Poses::Csv(w) => w.write_frame(record)?,
            Poses::OpenPose { dir, stem } => {
                write_openpose_frame(dir, stem, record)?;
            }
        }
        if let Some(g) = &mut self.gltf {
            let t = record.time_s.unwrap_or(record.frame as f64 / 30.0);
            if let Err(e) = g.add_record(t, record) {
                tracing::warn!("frame {}: not added to the glTF: {e}", record.frame);
            }
        }
        if let (Some(show), Some(frame)) = (&mut self.show, &image) {
            if !show.frame(frame, record, &self.cameras)? {
                crate::interrupt();
            }
            if self.single_image {
                self.last_shown = Some((frame.clone(), record.clone()));
            }
        }
        if let (Some(overlay), Some(mut frame)) = (&mut self.overlay, image) {
            let (w, h) = frame.dimensions();
            self.renderer
                .draw(&mut frame, &record.hands, &self.cameras, &self.layers);
            match overlay {
                Overlay::Video { path, fps, writer } => {
                    if writer.is_none() {
                        let (fw, fh) = (w as usize, h as usize);
                        let w = VideoWriter::create(&*path, fw, fh, *fps)?;
                        *writer = Some((w, fw, fh));
                    }
                    if let Some((wr, ww, wh)) = writer {
                        if (w as usize, h as usize) == (*ww, *wh) {
                            wr.write(&frame)?;
                        } else {
                            tracing::warn!(
                                "frame {}: size differs from the overlay video's; not drawn",
                                record.frame
                            );
                        }
                    }
                }
                Overlay::Folder(dir) => {
                    save_image(frame, &dir.join(format!("frame_{:06}.png", record.frame)))?
                }
                Overlay::Image(path) => save_image(frame, path)?,
            }
        }
        self.frames += 1;
        Ok(())
    }

    /// Closes every output (the overlay video is finalised so it plays).
    pub fn finish(mut self) -> Result<()> {
        if let (Some(show), Some((image, record))) = (&mut self.show, &self.last_shown) {
            if !crate::interrupted() {
                show.hold(image, record, &self.cameras)?;
            }
        }
        if let Some(g) = self.gltf {
            g.finish()?;
        }
        if let Some(Overlay::Video {
            writer: Some((w, _, _)),
            ..
        }) = self.overlay
        {
            w.finish()?;
        }
        Ok(())
    }
}

fn is_video_path(p: &Path) -> bool {
    has_extension(p, VIDEO_EXTENSIONS)
}

fn has_extension(p: &Path, extensions: &[&str]) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| extensions.contains(&e.to_ascii_lowercase().as_str()))
}

/// Writes an overlay frame as an image file (PNG or JPEG, by the name's extension), through
/// `.tmp-NAME` beside it and a rename, so a failed write leaves no damaged image.
fn save_image(frame: RgbImage, path: &Path) -> Result<()> {
    let name = path.file_name().unwrap_or(path.as_os_str());
    let mut tmp_name = std::ffi::OsString::from(".tmp-");
    tmp_name.push(name);
    let tmp = path.with_file_name(tmp_name);
    let written = frame
        .save(&tmp)
        .map_err(anyhow::Error::from)
        .and_then(|()| std::fs::rename(&tmp, path).map_err(anyhow::Error::from));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written.with_context(|| format!("cannot write {}", path.display()))
}
