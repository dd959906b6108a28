//! The terminal's side of a job, with a progress bar with frames per second on long runs,
//! drawn only when stderr is a terminal (and not with --quiet).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use monohand::engine::{Observer, RunReport};
use std::io::IsTerminal;

/// The CLI's side of a job: Ctrl-C and the window's Q cancel it, the progress bar follows
/// it, and the library's notes go to stderr with their flag.
pub(crate) struct Terminal {
    /// The bar (none for `detect`).
    pub progress: Progress,
}

impl Terminal {
    /// Without a bar.
    pub fn without_bar() -> Terminal {
        Terminal {
            progress: Progress { bar: None },
        }
    }
}

impl Observer for Terminal {
    fn cancelled(&self) -> bool {
        crate::interrupted()
    }

    fn frame_written(&self, report: &RunReport) {
        self.progress.tick(report.frames, report.hands);
    }

    fn note(&self, note: &monohand::Note) {
        crate::say(&crate::flagged(note));
    }
}

/// Progress of a run over frames.
pub(crate) struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    /// A bar over `total` frames (a spinner when unknown).
    pub fn new(total: Option<u64>) -> Progress {
        if crate::is_quiet() || !std::io::stderr().is_terminal() {
            return Progress { bar: None };
        }
        let bar = match total {
            Some(n) => ProgressBar::new(n).with_style(
                ProgressStyle::with_template(
                    "{bar:30} {pos}/{len} frames {per_sec} eta {eta} {msg}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            ),
            None => ProgressBar::new_spinner().with_style(
                ProgressStyle::with_template("{spinner} {pos} frames {per_sec} {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            ),
        };
        bar.set_draw_target(ProgressDrawTarget::stderr_with_hz(4));
        Progress { bar: Some(bar) }
    }

    /// `frames` done so far, `hands` found so far.
    pub fn tick(&self, frames: u64, hands: u64) {
        if let Some(b) = &self.bar {
            b.set_position(frames);
            b.set_message(format!("{hands} hands"));
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}
