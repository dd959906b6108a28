//! `run --show`: a live window with the overlay and the frame rate; its keys and its still
//! image are described in docs/visualisation.md. Quitting ends the run as Ctrl-C does. The
//! window is minifb's (X11 loaded at run time), behind the `show` cargo feature.

use anyhow::{anyhow, Result};
use minifb::{Key, KeyRepeat, Window, WindowOptions};
use monohand_core::camera::Camera;
use monohand_io::jsonl::FrameRecord;
use monohand_media::live::{draw_status, to_0rgb, FrameRate};
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
    /// The rate shown.
    rate: FrameRate,
    /// Layers, toggled by the keys 1-5.
    layers: Layers,
    renderer: SceneRenderer,
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
            rate: FrameRate::default(),
            layers,
            renderer: SceneRenderer::default(),
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
        let fps = self.rate.tick(Instant::now());
        let (w, h) = (image.width() as usize, image.height() as usize);
        self.step = false;
        let mut drawn: Option<Layers> = None;
        loop {
            if drawn != Some(self.layers) {
                let mut frame = image.clone();
                self.renderer
                    .draw_record(&mut frame, record, cameras, &self.layers);
                let state = if self.paused { "  PAUSED" } else { "" };
                let status = format!("{fps:.1} FPS  FRAME {}{state}", record.frame);
                draw_status(&mut frame, &status);
                to_0rgb(&frame, &mut self.buffer);
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
