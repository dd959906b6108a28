//! `run --show`: a live window with the overlay, the frame rate and, per hand, its id,
//! side and distance (the overlay's labels). Keys: Space pauses and resumes, `.` or → steps
//! one frame while paused, 1-5 toggle the layers (keypoints, model, bones, top view,
//! labels), Q or Esc quits. Quitting or closing the window ends the run as Ctrl-C does:
//! the current frame is finished and every output closed.
//!
//! A still image (one input image) stays on screen until the window is closed or Q.
//!
//! The window is minifb's (X11 loaded at run time: no system library is linked); it is
//! behind the `show` cargo feature (on by default).

use anyhow::{anyhow, Result};
use minifb::{Key, KeyRepeat, Window, WindowOptions};
use monohand_core::camera::Camera;
use monohand_io::jsonl::FrameRecord;
use monohand_media::overlay::draw_label;
use monohand_media::scene::{Layer, Layers, SceneRenderer};
use monohand_vision::RgbImage;
use std::time::{Duration, Instant};

/// The live window.
pub(crate) struct Show {
    window: Option<Window>,
    /// The frame as `0RGB` words, reused.
    buffer: Vec<u32>,
    paused: bool,
    /// Set by `.` while paused: let one frame through.
    step: bool,
    /// Frame times of the last second, for the rate shown.
    times: std::collections::VecDeque<Instant>,
    /// Layers, toggled by the keys 1-5.
    layers: Layers,
    renderer: SceneRenderer,
    /// Size of the frames shown.
    size: (usize, usize),
}

impl Show {
    /// A window is opened at the first frame (its size is the frame's); without a display
    /// (`DISPLAY` unset) this fails before any output is created.
    pub fn new(layers: Layers) -> Result<Show> {
        if std::env::var_os("DISPLAY").is_none_or(|d| d.is_empty()) {
            anyhow::bail!("--show needs an X display (DISPLAY is not set)");
        }
        Ok(Show {
            window: None,
            buffer: Vec::new(),
            paused: false,
            step: false,
            times: Default::default(),
            layers,
            renderer: SceneRenderer::default(),
            size: (0, 0),
        })
    }

    /// Shows a frame with its hands drawn on it; handles keys (a layer toggled redraws
    /// the frame); while paused, waits here (the window stays live) until resumed, stepped
    /// or closed. Returns `false` when the user quit or closed the window.
    pub fn frame(
        &mut self,
        image: &RgbImage,
        record: &FrameRecord,
        cameras: &[Camera],
    ) -> Result<bool> {
        let now = Instant::now();
        self.times.push_back(now);
        while self
            .times
            .front()
            .is_some_and(|t| now.duration_since(*t) > Duration::from_secs(1))
        {
            self.times.pop_front();
        }
        let fps = if self.times.len() > 1 {
            let span = now.duration_since(self.times[0]).as_secs_f64();
            (self.times.len() - 1) as f64 / span.max(1e-9)
        } else {
            0.0
        };
        let (w, h) = (image.width() as usize, image.height() as usize);
        self.size = (w, h);
        self.step = false;
        let mut drawn: Option<Layers> = None;
        loop {
            if drawn != Some(self.layers) {
                let mut frame = image.clone();
                let source = record.cameras.first().map(|c| c.source.name());
                self.renderer.set_camera_source(source);
                self.renderer
                    .draw(&mut frame, &record.hands, cameras, &self.layers);
                let scale = ((w.max(h) as f64 / 640.0).round() as usize).max(1);
                let state = if self.paused { "  PAUSED" } else { "" };
                draw_label(
                    &mut frame,
                    &format!("{fps:.1} FPS  FRAME {}{state}", record.frame),
                    [4.0, 4.0],
                    scale,
                    [255, 255, 255],
                    [0, 0, 0],
                );
                self.buffer.clear();
                self.buffer.extend(
                    frame
                        .pixels()
                        .map(|p| (p.0[0] as u32) << 16 | (p.0[1] as u32) << 8 | p.0[2] as u32),
                );
                drawn = Some(self.layers);
            }
            if self.window.is_none() {
                let mut win = Window::new("monohand", w, h, WindowOptions::default())
                    .map_err(|e| anyhow!("--show: cannot open a window ({e}); is DISPLAY set?"))?;
                win.set_target_fps(0);
                self.window = Some(win);
            }
            let Some(win) = self.window.as_mut() else {
                return Ok(false);
            };
            win.update_with_buffer(&self.buffer, w, h)
                .map_err(|e| anyhow!("--show: {e}"))?;
            if !win.is_open() {
                return Ok(false);
            }
            for key in win.get_keys_pressed(KeyRepeat::No) {
                match key {
                    Key::Q | Key::Escape => return Ok(false),
                    Key::Space => {
                        self.paused = !self.paused;
                        drawn = None;
                    }
                    Key::Period | Key::Right => self.step = true,
                    Key::Key1 => self.layers.toggle(Layer::Keypoints),
                    Key::Key2 => self.layers.toggle(Layer::Model),
                    Key::Key3 => self.layers.toggle(Layer::Bones),
                    Key::Key4 => self.layers.toggle(Layer::Top),
                    Key::Key5 => self.layers.toggle(Layer::Labels),
                    _ => {}
                }
            }
            if !self.paused || self.step {
                return Ok(true);
            }
            std::thread::sleep(Duration::from_millis(15));
        }
    }

    /// For a still image: keeps the frame on screen (keys still work) until the window is
    /// closed or Q.
    pub fn hold(
        &mut self,
        image: &RgbImage,
        record: &FrameRecord,
        cameras: &[Camera],
    ) -> Result<()> {
        self.paused = true;
        while self.frame(image, record, cameras)? {}
        Ok(())
    }
}
