//! What a live view of the frames needs beside the scene: the frame rate of the last second,
//! a status line drawn on the frame, and the frame packed as `0RGB` words for a window.

use crate::overlay::draw_label;
use crate::RgbImage;
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// The rate of the frames shown over the last second.
#[derive(Debug, Clone, Default)]
pub struct FrameRate {
    times: VecDeque<Instant>,
}

impl FrameRate {
    /// Counts a frame shown at `now`; returns the frames per second over the second up to
    /// `now` (0 before a second frame).
    pub fn tick(&mut self, now: Instant) -> f64 {
        self.times.push_back(now);
        while self
            .times
            .front()
            .is_some_and(|t| now.duration_since(*t) > Duration::from_secs(1))
        {
            self.times.pop_front();
        }
        match self.times.front() {
            Some(first) if self.times.len() > 1 => {
                let span = now.duration_since(*first).as_secs_f64();
                (self.times.len() - 1) as f64 / span.max(1e-9)
            }
            _ => 0.0,
        }
    }
}

/// Draws `text` white on black in the frame's top-left corner, in letters that grow with
/// the frame (one pixel per font pixel up to 640 pixels across).
pub fn draw_status(frame: &mut RgbImage, text: &str) {
    let longest = frame.width().max(frame.height()) as f64;
    let scale = ((longest / 640.0).round() as usize).max(1);
    draw_label(frame, text, [4.0, 4.0], scale, [255, 255, 255], [0, 0, 0]);
}

/// The frame as `0RGB` words, row by row, into `out` (cleared first).
pub fn to_0rgb(frame: &RgbImage, out: &mut Vec<u32>) {
    out.clear();
    out.extend(
        frame
            .pixels()
            .map(|p| (p.0[0] as u32) << 16 | (p.0[1] as u32) << 8 | p.0[2] as u32),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rate_counts_the_frames_of_the_last_second() {
        let start = Instant::now();
        let mut rate = FrameRate::default();
        assert_eq!(rate.tick(start), 0.0);
        let ms = |n: u64| start + Duration::from_millis(n);
        assert!((rate.tick(ms(100)) - 10.0).abs() < 1e-9);
        for n in 2..=20 {
            rate.tick(ms(100 * n));
        }
        // Frames at 1.0 s .. 2.0 s are within the last second: 10 intervals over 1 s.
        assert!((rate.tick(ms(2100)) - 10.0).abs() < 1e-9);
    }

    #[test]
    fn a_status_line_is_drawn_at_the_corner_and_pixels_pack_as_0rgb() {
        let mut frame = RgbImage::from_pixel(64, 32, image::Rgb([10, 20, 30]));
        draw_status(&mut frame, "10.0 FPS");
        assert_eq!(frame.get_pixel(4, 4).0, [0, 0, 0], "the label's background");
        assert_eq!(frame.get_pixel(63, 31).0, [10, 20, 30], "untouched");
        let mut out = vec![7];
        to_0rgb(&frame, &mut out);
        assert_eq!(out.len(), 64 * 32);
        assert_eq!(out[63 + 31 * 64], 0x000a_141e);
    }
}
