//! The project's output records ([`monohand_io::jsonl`]) of the session's results: one
//! definition for `monohand run`, `monohand detect` and the Python package, so that they
//! write the same numbers.

use crate::base::frame::FittedFrame;
use crate::stages::rig_check::view_fits;
use monohand_core::observation::Keypoints2d;
use monohand_io::jsonl::{
    CameraRecord, DistanceRecord, FrameRecord, HandRecord, HeadRecord, OrientedBox, PoseRecord,
};
use monohand_vision::{DetectedHand, Detections};

/// The record of one detected hand: its keypoints, boxes, scores and the network's 3D cues.
pub fn hand_record(hand: &DetectedHand) -> HandRecord {
    let r = &hand.oriented_box;
    let mut record = HandRecord::from_keypoints(hand.side, &hand.keypoints);
    record.bbox = Some(hand.keypoints.bounds());
    record.score = Some(f64::from(hand.detection_score));
    record.side_score = Some(f64::from(hand.side_score));
    record.oriented_box = Some(OrientedBox {
        center: r.center,
        size: [r.width, r.height],
        angle_deg: r.rotation.to_degrees(),
    });
    record.with_cues(hand.cues.as_ref())
}

/// The record of one image's detections (2D only).
pub fn detections_record(frame: u64, source: Option<String>, found: &Detections) -> FrameRecord {
    FrameRecord {
        frame,
        source,
        image_size: Some([found.image_size.0, found.image_size.1]),
        hands: found.hands.iter().map(hand_record).collect(),
        heads: found
            .heads
            .iter()
            .map(|h| HeadRecord {
                bbox: h.head_box,
                score: f64::from(h.score),
            })
            .collect(),
        precision: (found.precision != monohand_vision::Precision::F32)
            .then(|| found.precision.name().to_owned()),
        ..FrameRecord::default()
    }
}

/// The record of a fitted frame: the first view's detections with each hand's id, voted
/// side and 3D, then the hands only later views see. Time and timings are the caller's.
pub fn fitted_record(done: &FittedFrame, source: Option<String>) -> FrameRecord {
    let vision = &done.vision;
    let mut record = match vision.views.first() {
        Some(Ok(first)) => detections_record(vision.index, source, &first.detections),
        Some(Err(e)) => FrameRecord {
            frame: vision.index,
            source,
            error: Some(e.to_string()),
            ..FrameRecord::default()
        },
        None => FrameRecord {
            frame: vision.index,
            source,
            ..FrameRecord::default()
        },
    };
    if let Some(e) = &done.error {
        record.error = Some(e.clone());
    }
    record.cameras = done
        .cameras
        .iter()
        .zip(&done.camera_origins)
        .map(|(c, o)| CameraRecord::new(c, o.source).with_reason(o.reason.clone()))
        .collect();
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
                    rec.hand_size = done.hand_size.clone();
                    rec.joints_3d_mm = Some(fit.joints_3d.map(|x| [x.x, x.y, x.z]));
                    rec.pose = Some(PoseRecord::from_pose(&fit.pose));
                    rec.reprojection_error_px = Some(fit.reprojection_error_px);
                    rec.converged = Some(fit.converged);
                    rec.iterations = Some(fit.iterations);
                    rec.views = view_fits(done, hand);
                    rec.distance = hand
                        .distance
                        .as_ref()
                        .filter(|e| e.fused_mm.is_finite() && e.fused_sigma_mm.is_finite())
                        .map(DistanceRecord::from);
                }
            }
            // Only other views see it: no keypoints in the first view, the 3D in its frame.
            _ => {
                if let Some(fit) = &hand.fit {
                    let mut rec = HandRecord::from_fit(hand.side, &Keypoints2d::default(), fit);
                    rec.id = Some(hand.id);
                    rec.hand_size = done.hand_size.clone();
                    rec.views = view_fits(done, hand);
                    record.hands.push(rec);
                }
            }
        }
    }
    record
}

/// [`fitted_record`] with the frame's time (`with_time`: a video's frames) and the stage
/// timings: `decode` (when the caller decoded the frame), `vision` and `fit`. What
/// `monohand run` writes, and the browser build (monohand-web) too.
pub fn timed_record(
    done: &FittedFrame,
    source: Option<String>,
    with_time: bool,
    decode_ms: Option<f64>,
) -> FrameRecord {
    let mut record = fitted_record(done, source);
    if with_time {
        record.time_s = Some(done.vision.time_s);
    }
    record.timings_ms = Some(
        decode_ms
            .map(|ms| ("decode".to_string(), ms))
            .into_iter()
            .chain([
                ("vision".to_string(), done.vision.vision_ms),
                ("fit".to_string(), done.fit_ms),
            ])
            .collect(),
    );
    record
}
