//! A live window as a sink (`run --show`): each frame with its hands drawn and the frame
//! rate; its keys and its still image are described in docs/visualisation.md. The window is
//! `monohand_media::window`'s: a build without its `window` feature refuses to open one
//! ([`WindowError::NotBuilt`]).

use super::{Output, Sink, SinkError};
use monohand_core::camera::Camera;
use monohand_io::jsonl::FrameRecord;
use monohand_media::live::{draw_status, FrameRate};
use monohand_media::scene::{Layer, Layers, SceneRenderer};
use monohand_media::window::{Window, WindowError, WindowKey};
use monohand_vision::RgbImage;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The live window. Space pauses, S steps one frame, 1-5 toggle the layers (keypoints,
/// model, bones, top view, labels), Q or closing the window quits: the sink then raises
/// its stop flag (the caller's: stop the run there, as for Ctrl-C) and shows nothing more.
pub struct WindowSink {
    window: Window,
    paused: bool,
    /// The rate shown.
    rate: FrameRate,
    /// Layers, toggled by the keys 1-5.
    layers: Layers,
    renderer: SceneRenderer,
    /// The input is one image: the window keeps it on screen at the end.
    single_image: bool,
    /// The last frame shown, for that.
    last: Option<(RgbImage, FrameRecord, Vec<Camera>)>,
    /// Raised when the user quits; once raised (by either side), nothing more is shown.
    stop: Arc<AtomicBool>,
}

impl WindowSink {
    /// A window titled `title` drawing `layers`; it opens at the first frame (its size is
    /// the frame's). Without a display this fails before any output is created.
    /// `single_image`: the input is one image, kept on screen at the end until closed
    /// (unless `stop` was raised).
    pub fn open(
        title: &str,
        layers: Layers,
        single_image: bool,
        stop: Arc<AtomicBool>,
    ) -> Result<WindowSink, WindowError> {
        Ok(WindowSink {
            window: Window::new(title)?,
            paused: false,
            rate: FrameRate::default(),
            layers,
            renderer: SceneRenderer::default(),
            single_image,
            last: None,
            stop,
        })
    }

    /// Shows a frame with its hands drawn on it; handles keys (a layer toggled redraws
    /// the frame); while paused, waits here (the window stays live) until resumed, stepped
    /// or closed. Returns `false` when the user quit or closed the window.
    fn show(
        &mut self,
        image: &RgbImage,
        record: &FrameRecord,
        cameras: &[Camera],
    ) -> Result<bool, WindowError> {
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
            let shown = self.window.show(&frame)?;
            if shown.quit() {
                return Ok(false);
            }
            for key in shown.keys {
                self.key(key, &mut step, &mut drawn);
            }
            if !self.paused || step {
                return Ok(true);
            }
            std::thread::sleep(Duration::from_millis(15));
        }
    }

    /// Acts on a key: pause, step, or a layer toggled (`drawn` is cleared to redraw).
    fn key(&mut self, key: WindowKey, step: &mut bool, drawn: &mut Option<Layers>) {
        match key {
            WindowKey::Space => {
                self.paused = !self.paused;
                *drawn = None;
            }
            WindowKey::Step => *step = true,
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

    fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

impl Sink for WindowSink {
    fn wants_images(&self) -> bool {
        true
    }

    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError> {
        let Some(image) = frame.image else {
            return Ok(());
        };
        if self.stopped() {
            return Ok(());
        }
        if !self.show(image, frame.record, frame.cameras)? {
            self.stop.store(true, Ordering::Relaxed);
        }
        if self.single_image {
            self.last = Some((image.clone(), frame.record.clone(), frame.cameras.to_vec()));
        }
        Ok(())
    }

    /// For a still image: keeps the frame on screen (keys still work) until the window is
    /// closed or Q.
    fn finish(&mut self) -> Result<(), SinkError> {
        if let Some((image, record, cameras)) = self.last.take() {
            if !self.stopped() {
                self.paused = true;
                while self.show(&image, &record, &cameras)? {}
            }
        }
        Ok(())
    }
}
