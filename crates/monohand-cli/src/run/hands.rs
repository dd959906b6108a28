//! The records `monohand run` writes, from the session's frames
//! ([`monohand::FittedFrame`]).

use crate::vision::frame_record;
use monohand::FittedFrame;
use monohand_core::observation::Keypoints2d;
use monohand_io::jsonl::{FrameRecord, HandRecord, PoseRecord};
use monohand_vision::RgbImage;

/// What `run` carries beside each frame through the session's stages.
pub(crate) struct FrameExtra {
    /// File name, if any.
    pub source: Option<String>,
    /// Whether the frame came from a video (its time is then written out).
    pub is_video: bool,
    /// The first view's image, for overlays.
    pub image: Option<RgbImage>,
    /// Time spent decoding, ms.
    pub decode_ms: f64,
}

/// A finished frame and, for overlays, its first view's image.
pub(crate) type Done = (FrameRecord, Option<RgbImage>);

/// The output record of a fitted frame.
pub(crate) fn record(done: &FittedFrame, extra: FrameExtra) -> Done {
    let vision = &done.vision;
    let mut record = match vision.views.first() {
        Some(Ok(first)) => frame_record(vision.index, extra.source, &first.detections),
        Some(Err(e)) => FrameRecord {
            frame: vision.index,
            source: extra.source,
            error: Some(e.clone()),
            ..FrameRecord::default()
        },
        None => FrameRecord::default(),
    };
    if let Some(e) = &done.error {
        record.error = Some(e.clone());
    }
    for hand in &done.hands {
        match hand.views.first() {
            // A hand of the first view: its record is the detection's, with the 3D added.
            Some(&(0, k)) => {
                let Some(rec) = record.hands.get_mut(k) else {
                    continue;
                };
                rec.id = Some(hand.id);
                if hand.side != rec.side {
                    // The vote over the track overrules this frame's network.
                    rec.side = hand.side;
                    rec.side_score = rec.side_score.map(|p| 1.0 - p);
                }
                if let Some(fit) = &hand.fit {
                    rec.joints_3d_mm = Some(fit.joints_3d.map(|x| [x.x, x.y, x.z]));
                    rec.pose = Some(PoseRecord::from_pose(&fit.pose));
                    rec.reprojection_error_px = Some(fit.reprojection_error_px);
                    rec.converged = Some(fit.converged);
                    rec.iterations = Some(fit.iterations);
                }
            }
            // Only other views see it: no keypoints in the first view, the 3D in its frame.
            _ => {
                if let Some(fit) = &hand.fit {
                    let mut rec = HandRecord::from_fit(hand.side, &Keypoints2d::default(), fit);
                    rec.id = Some(hand.id);
                    record.hands.push(rec);
                }
            }
        }
    }
    if extra.is_video {
        record.time_s = Some(vision.time_s);
    }
    record.timings_ms = Some(
        [
            ("decode".to_string(), extra.decode_ms),
            ("vision".to_string(), vision.vision_ms),
            ("fit".to_string(), done.fit_ms),
        ]
        .into_iter()
        .collect(),
    );
    (record, extra.image)
}
