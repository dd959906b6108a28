//! `run --show`: a live window with the overlay and the frame rate; its keys and its still
//! image are described in docs/visualisation.md. Quitting ends the run as Ctrl-C does. The
//! window is `monohand_media::window`'s, behind the `show` cargo feature.

use anyhow::{Context, Result};
use monohand_core::camera::Camera;
use monohand_io::jsonl::FrameRecord;
use monohand_media::live::{draw_status, FrameRate};
use monohand_media::scene::{Layer, Layers, SceneRenderer};
use monohand_media::window::{Window, WindowKey};
use monohand_vision::RgbImage;
use std::time::{Duration, Instant};

/// The live window.
pub(crate) struct Show {
    window: Window,
    paused: bool,
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
        Ok(Show {
            window: Window::new("monohand").context("--show")?,
            paused: false,
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
        let mut step = false;
        let mut frame = image.clone();
        let mut drawn: Option<Layers> = None;
        loop {
            if drawn != Some(self.layers) {
                frame.clone_from(image);
                self.renderer
                    .draw_record(&mut frame, record, cameras, &self.layers);
                let state = if self.paused { "  PAUSED" } else { "" };
                draw_status(
                    &mut frame,
                    &format!("{fps:.1} FPS  FRAME {}{state}", record.frame),
                );
                drawn = Some(self.layers);
            }
            let shown = self.window.show(&frame).context("--show")?;
            if shown.quit() {
                return Ok(false);
            }
            for key in shown.keys {
                match key {
                    WindowKey::Space => {
                        self.paused = !self.paused;
                        drawn = None;
                    }
                    WindowKey::Step => step = true,
                    WindowKey::Digit(d) => {
                        let layers = [Layer::Keypoints, Layer::Model, Layer::Bones, Layer::Top];
                        match d {
                            1..=4 => self.layers.toggle(layers[d as usize - 1]),
                            5 => self.layers.toggle(Layer::Labels),
                            _ => {}
                        }
                    }
                    WindowKey::Quit => {}
                }
            }
            if !self.paused || step {
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
