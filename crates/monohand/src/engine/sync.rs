//! Views that did not start together: each view's time offset against the first, found
//! from the hands its frames show ([`find_offsets`], the geometry in
//! [`monohand_core::sync`]), and each view's frames matched to the first view's by time
//! ([`align`]).
//!
//! Matching by time also serves views of different or variable frame rates: for each frame
//! of the first view, each other view gives its frame nearest to the same moment (the
//! same frame again for a slower view, frames skipped for a faster one), and a frame from
//! before the view started or after it ended is said in the record, not made up.

use super::source::{FrameSource, InputError, SourceFrame};
use crate::base::errors::SourceError;
use crate::settings::ResolvedSettings;
use crate::stages::crops::CropTracker;
use monohand_core::camera::Camera;
use monohand_core::sync::{rig_offsets, SyncSettings, ViewFrames, ViewOffset};
use monohand_vision::HandPipeline;
use std::sync::Arc;

/// The frames of each view [`find_offsets`] reads by default: 20 s at 30 fps.
pub const SYNC_FRAMES: u64 = 600;

/// Reads up to `max_frames` frames of each of `sources` (one per view, in the order of
/// `cameras`), finds the hands in each view on its own (tracked as the settings say), and
/// gives each view's offset against the first
/// (the first's own: zero), the rig solved as a whole ([`rig_offsets`]).
pub fn find_offsets(
    pipeline: &Arc<HandPipeline>,
    settings: &ResolvedSettings,
    cameras: &[Camera],
    sources: Vec<Box<dyn FrameSource>>,
    max_frames: u64,
    sync: &SyncSettings,
) -> Result<Vec<ViewOffset>, InputError> {
    let lenses = settings.lenses(cameras);
    let mut views = Vec::with_capacity(sources.len());
    for (v, source) in sources.into_iter().enumerate() {
        let lens = lenses.get(v).copied().flatten();
        views.push(hands_of(
            pipeline,
            settings,
            lens,
            source,
            max_frames,
            cameras.get(v),
        )?);
    }
    let rig: Vec<(&Camera, &[ViewFrames])> = views.iter().map(|(c, f)| (c, f.as_slice())).collect();
    Ok(rig_offsets(&rig, sync))
}

/// One view's camera (scaled to its frames) and the hands in each of its first
/// `max_frames` frames, times from its first frame.
fn hands_of(
    pipeline: &Arc<HandPipeline>,
    settings: &ResolvedSettings,
    lens: Option<Camera>,
    mut source: Box<dyn FrameSource>,
    max_frames: u64,
    camera: Option<&Camera>,
) -> Result<(Camera, Vec<ViewFrames>), InputError> {
    let mut crops = CropTracker::new(Arc::clone(pipeline), 1, settings.crops(&[]));
    crops.rectify_through(vec![lens]);
    let mut camera = camera.copied();
    let mut frames = Vec::new();
    let mut origin = None;
    while (frames.len() as u64) < max_frames {
        let f = match source.next_frame() {
            Ok(Some(f)) => f,
            // A view that ends on an error is judged on its good frames.
            Ok(None) | Err(_) => break,
        };
        let t0 = *origin.get_or_insert(f.timestamp_s);
        if let (Ok(image), Some(c)) = (&f.image, camera) {
            camera = c.scaled_to(image.width(), image.height()).ok().or(Some(c));
        }
        let vision = crops.process(
            f.index,
            f.timestamp_s,
            &[f.image.as_ref().map_err(Clone::clone)],
        );
        let hands = match vision.views.first() {
            Some(Ok(v)) => v.detections.hands.iter().map(|h| h.keypoints).collect(),
            _ => Vec::new(),
        };
        frames.push(ViewFrames::new(f.timestamp_s - t0, hands));
    }
    let camera = camera.ok_or(InputError::Uncalibrated)?;
    Ok((camera, frames))
}

/// The views of `sources` matched by time: every view after the first gives, for each
/// frame of the first, its frame nearest to the same moment, `offsets_s[v]` being how late
/// view `v` started ([`monohand_core::sync::FoundOffset::offset_s`]; missing: 0).
pub fn align(sources: Vec<Box<dyn FrameSource>>, offsets_s: &[f64]) -> Vec<Box<dyn FrameSource>> {
    sources
        .into_iter()
        .enumerate()
        .map(|(v, s)| -> Box<dyn FrameSource> {
            if v == 0 {
                s
            } else {
                Box::new(Aligned::new(
                    s,
                    v + 1,
                    offsets_s.get(v).copied().unwrap_or(0.0),
                ))
            }
        })
        .collect()
}

/// A later view's frames, by time.
struct Aligned {
    inner: Box<dyn FrameSource>,
    /// The view, from 1.
    view: usize,
    /// How late it started, seconds.
    offset_s: f64,
    /// The first view's first frame time, and this view's.
    origins: (Option<f64>, Option<f64>),
    /// The frame last given or passed (its time from this view's first) and the next one.
    current: Option<(f64, SourceFrame)>,
    next: Option<(f64, SourceFrame)>,
    /// The median spacing of its frames so far, seconds.
    spacing_s: Option<f64>,
    /// The inner source has ended (or stopped on this error).
    ended: Option<Option<SourceError>>,
}

impl Aligned {
    fn new(inner: Box<dyn FrameSource>, view: usize, offset_s: f64) -> Aligned {
        Aligned {
            inner,
            view,
            offset_s,
            origins: (None, None),
            current: None,
            next: None,
            spacing_s: None,
            ended: None,
        }
    }

    /// Reads the inner source's next frame into `next`, if there is one.
    fn pull(&mut self) {
        if self.ended.is_some() || self.next.is_some() {
            return;
        }
        match self.inner.next_frame() {
            Ok(Some(f)) => {
                let t0 = *self.origins.1.get_or_insert(f.timestamp_s);
                let local = f.timestamp_s - t0;
                if let Some((prev, _)) = &self.current {
                    let d = local - prev;
                    if d > 0.0 {
                        self.spacing_s = Some(self.spacing_s.map_or(d, |s| 0.9 * s + 0.1 * d));
                    }
                }
                self.next = Some((local, f));
            }
            Ok(None) => self.ended = Some(None),
            Err(e) => self.ended = Some(Some(e)),
        }
    }

    /// A copy of the frame `f` of this view, for `index` of the first view.
    fn copy(f: &SourceFrame, index: u64) -> SourceFrame {
        SourceFrame {
            index,
            source: f.source.clone(),
            timestamp_s: f.timestamp_s,
            image: f.image.clone(),
            decode_ms: f.decode_ms,
            focal: f.focal.clone(),
        }
    }
}

impl FrameSource for Aligned {
    fn next_frame(&mut self) -> Result<Option<SourceFrame>, SourceError> {
        self.inner.next_frame()
    }

    fn frame_at(&mut self, index: u64, time_s: f64) -> Result<Option<SourceFrame>, SourceError> {
        let master = time_s - *self.origins.0.get_or_insert(time_s);
        let target = master - self.offset_s;
        self.pull();
        // Step on while the next frame is no later than the moment.
        while self.next.as_ref().is_some_and(|(t, _)| *t <= target) {
            self.current = self.next.take();
            self.pull();
        }
        let half = 0.5 * self.spacing_s.unwrap_or(1.0 / 30.0) + 1e-6;
        let near = |x: &Option<(f64, SourceFrame)>| x.as_ref().map(|(t, _)| (t - target).abs());
        let pick = match (near(&self.current), near(&self.next)) {
            (Some(a), Some(b)) if b < a => self.next.as_ref(),
            (Some(_), _) => self.current.as_ref(),
            (None, Some(_)) => self.next.as_ref(),
            (None, None) => None,
        };
        match pick {
            Some((t, f)) if (t - target).abs() <= half => Ok(Some(Aligned::copy(f, index))),
            Some((t, _)) if *t > target => {
                Ok(Some(self.missing(index, time_s, "has not started yet")))
            }
            _ => match &self.ended {
                Some(Some(e)) => Err(e.clone()),
                Some(None) => Ok(None),
                None => Ok(Some(self.missing(index, time_s, "has no frame then"))),
            },
        }
    }

    fn is_video(&self) -> bool {
        self.inner.is_video()
    }
    fn len_hint(&self) -> Option<u64> {
        self.inner.len_hint()
    }
    fn fps(&self) -> Option<f64> {
        self.inner.fps()
    }
    fn video_size(&self) -> Option<(u32, u32)> {
        self.inner.video_size()
    }
    fn rotation_deg(&self) -> i32 {
        self.inner.rotation_deg()
    }
}

impl Aligned {
    /// A frame without an image: the view had none at that moment.
    fn missing(&self, index: u64, time_s: f64, what: &str) -> SourceFrame {
        SourceFrame {
            index,
            source: None,
            timestamp_s: time_s,
            image: Err(SourceError::Other(format!(
                "view {} {what} ({:+.3} s against view 1)",
                self.view, self.offset_s
            ))),
            decode_ms: 0.0,
            focal: crate::StatedCamera::None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::CallerFrames;
    use monohand_vision::RgbImage;

    /// `n` frames at `fps` from time `t0`, each a 1x1 image whose red value is its index.
    fn clip(n: u8, fps: f64, t0: f64) -> Box<dyn FrameSource> {
        let frames: Vec<(RgbImage, f64)> = (0..n)
            .map(|i| {
                (
                    RgbImage::from_pixel(1, 1, image::Rgb([i, 0, 0])),
                    t0 + f64::from(i) / fps,
                )
            })
            .collect();
        Box::new(CallerFrames::new(frames.into_iter(), true))
    }

    /// What view 2 gives for each of view 1's `n` frames at 30 fps: its frame's index, or
    /// `-1` for a frame it had none for; `None` once it has ended.
    fn matched(mut view: Box<dyn FrameSource>, n: u64) -> Vec<Option<i32>> {
        (0..n)
            .map(|i| {
                let f = view.frame_at(i, 5.0 + i as f64 / 30.0).expect("no error")?;
                Some(f.image.map_or(-1, |im| i32::from(im.get_pixel(0, 0)[0])))
            })
            .collect()
    }

    #[test]
    fn a_later_view_gives_its_frame_of_the_same_moment() {
        // Started 2 frames late (its own clock from 100 s): nothing for the first two.
        let late = align(
            vec![clip(1, 30.0, 0.0), clip(6, 30.0, 100.0)],
            &[0.0, 2.0 / 30.0],
        );
        let got = matched(late.into_iter().nth(1).unwrap(), 9);
        let want = [-1, -1, 0, 1, 2, 3, 4, 5].map(Some);
        assert_eq!(got[..8], want, "{got:?}");
        assert_eq!(got[8], None);
        // Started 2 frames early: its first two are passed.
        let early = align(
            vec![clip(1, 30.0, 0.0), clip(6, 30.0, 0.0)],
            &[0.0, -2.0 / 30.0],
        );
        let got = matched(early.into_iter().nth(1).unwrap(), 4);
        assert_eq!(got, [2, 3, 4, 5].map(Some));
        // At 15 fps: each of its frames twice (4 ms late: no moment halfway between two of
        // its frames); at 60: every other one.
        let slow = align(vec![clip(1, 30.0, 0.0), clip(4, 15.0, 0.0)], &[0.0, 0.004]);
        let got = matched(slow.into_iter().nth(1).unwrap(), 8);
        assert_eq!(got, [0, 0, 1, 1, 2, 2, 3, 3].map(Some));
        let fast = align(vec![clip(1, 30.0, 0.0), clip(8, 60.0, 0.0)], &[0.0, 0.0]);
        let got = matched(fast.into_iter().nth(1).unwrap(), 4);
        assert_eq!(got, [0, 2, 4, 6].map(Some));
    }
}
