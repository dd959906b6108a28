//! A live window that shows frames and reports the keys pressed: minifb with X11 loaded at
//! run time (no system library linked), behind the `window` cargo feature. Without the
//! feature, [`Window::new`] refuses with [`WindowError::NotBuilt`], so a headless build says
//! why instead of failing later.

use crate::RgbImage;

/// A key the window reports; the others are ignored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WindowKey {
    /// Q or Escape.
    Quit,
    /// The space bar.
    Space,
    /// `.` or the right arrow.
    Step,
    /// A digit key, 0-9.
    Digit(u8),
}

/// Why the window could not be opened or updated.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum WindowError {
    /// `DISPLAY` is not set.
    #[error("needs an X display (DISPLAY is not set)")]
    NoDisplay,
    /// This build has no window.
    #[error("this monohand was built without the window (the `show` feature)")]
    NotBuilt,
    /// The window system refused.
    #[error("cannot open a window ({0})")]
    Failed(String),
}

/// What the user did since the last frame shown.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Shown {
    /// The window was closed.
    pub closed: bool,
    /// Keys pressed, in order.
    pub keys: Vec<WindowKey>,
}

impl Shown {
    /// The window was closed, or Q or Escape pressed.
    pub fn quit(&self) -> bool {
        self.closed || self.keys.contains(&WindowKey::Quit)
    }
}

#[cfg(feature = "window")]
mod imp {
    use super::{Shown, WindowError, WindowKey};
    use crate::live::to_0rgb;
    use crate::RgbImage;
    use minifb::{Key, KeyRepeat, WindowOptions};

    /// A live window, opened at the first frame with that frame's size.
    pub struct Window {
        title: String,
        window: Option<minifb::Window>,
        /// The frame as `0RGB` words, reused.
        buffer: Vec<u32>,
    }

    impl Window {
        /// A window with this title; fails at once without an X display (before any output
        /// is written).
        pub fn new(title: &str) -> Result<Window, WindowError> {
            if std::env::var_os("DISPLAY").is_none_or(|d| d.is_empty()) {
                return Err(WindowError::NoDisplay);
            }
            Ok(Window {
                title: title.to_string(),
                window: None,
                buffer: Vec::new(),
            })
        }

        /// Shows a frame and returns the keys pressed since the last one.
        pub fn show(&mut self, frame: &RgbImage) -> Result<Shown, WindowError> {
            let (w, h) = (frame.width() as usize, frame.height() as usize);
            to_0rgb(frame, &mut self.buffer);
            if self.window.is_none() {
                let mut win = minifb::Window::new(&self.title, w, h, WindowOptions::default())
                    .map_err(|e| WindowError::Failed(e.to_string()))?;
                win.set_target_fps(0);
                self.window = Some(win);
            }
            let Some(win) = self.window.as_mut() else {
                return Ok(Shown {
                    closed: true,
                    keys: Vec::new(),
                });
            };
            win.update_with_buffer(&self.buffer, w, h)
                .map_err(|e| WindowError::Failed(e.to_string()))?;
            let keys = win
                .get_keys_pressed(KeyRepeat::No)
                .into_iter()
                .filter_map(key)
                .collect();
            Ok(Shown {
                closed: !win.is_open(),
                keys,
            })
        }
    }

    fn key(k: Key) -> Option<WindowKey> {
        let digits = [
            Key::Key0,
            Key::Key1,
            Key::Key2,
            Key::Key3,
            Key::Key4,
            Key::Key5,
            Key::Key6,
            Key::Key7,
            Key::Key8,
            Key::Key9,
        ];
        match k {
            Key::Q | Key::Escape => Some(WindowKey::Quit),
            Key::Space => Some(WindowKey::Space),
            Key::Period | Key::Right => Some(WindowKey::Step),
            _ => digits
                .iter()
                .position(|d| *d == k)
                .map(|i| WindowKey::Digit(i as u8)),
        }
    }
}

#[cfg(not(feature = "window"))]
mod imp {
    use super::{Shown, WindowError};
    use crate::RgbImage;

    /// Never built: [`Window::new`] refuses.
    pub enum Window {}

    impl Window {
        /// Refuses: this build has no window.
        pub fn new(_title: &str) -> Result<Window, WindowError> {
            Err(WindowError::NotBuilt)
        }

        /// Unreachable (no `Window` exists).
        pub fn show(&mut self, _frame: &RgbImage) -> Result<Shown, WindowError> {
            match *self {}
        }
    }
}

pub use imp::Window;

impl Window {
    /// Keeps a picture on screen until the window is closed or Q.
    pub fn hold(&mut self, picture: &RgbImage) -> Result<(), WindowError> {
        while !self.show(picture)?.quit() {
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        Ok(())
    }
}
