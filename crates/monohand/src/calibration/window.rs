//! The live window of `calibrate --show`: each frame as the calibration sees it (the
//! corners found, the views kept, the parts of the image still to cover), then the result
//! or the reason there is none, until closed. The window is `monohand_media::window`'s.

use super::{draw_seen, picture, Calibrated, SeenFrame};
use monohand_media::live::draw_status;
use monohand_media::window::{Window, WindowError};
use monohand_vision::RgbImage;

/// A calibration's live window.
pub struct CalibrationWindow {
    window: Window,
    /// The last frame shown, for a message on it at the end.
    last: Option<RgbImage>,
}

impl CalibrationWindow {
    /// A window titled `title`, opened at the first frame. Without a display this fails
    /// before anything is read.
    pub fn open(title: &str) -> Result<CalibrationWindow, WindowError> {
        Ok(CalibrationWindow {
            window: Window::new(title)?,
            last: None,
        })
    }

    /// Shows a frame with what was found on it; `Ok(false)` once the window is closed or Q.
    pub fn frame(&mut self, seen: &SeenFrame<'_>) -> Result<bool, WindowError> {
        let mut frame = seen.image.clone();
        draw_seen(&mut frame, seen);
        let shown = self.window.show(&frame);
        self.last = Some(frame);
        Ok(!shown?.quit())
    }

    /// Keeps the last frame on screen with `text` on it until closed (nothing if no frame
    /// was shown).
    pub fn hold_text(&mut self, text: &str) -> Result<(), WindowError> {
        match self.last.take() {
            Some(mut frame) => {
                draw_status(&mut frame, &text.to_uppercase());
                self.window.hold(&frame)
            }
            None => Ok(()),
        }
    }

    /// Keeps the result on screen until closed: the first camera's views and distortion.
    pub fn hold_result(&mut self, calibrated: &Calibrated) -> Result<(), WindowError> {
        self.window.hold(&picture(calibrated, 0))
    }
}
