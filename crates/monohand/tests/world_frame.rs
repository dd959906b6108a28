//! A fit does not depend on where the world frame is (issue 56): on real frames of the
//! table rig (`../shared/data/table_rig_dev`, real networks, tracked), a mono view's records
//! are the same, mapped through its extrinsics, whether or not its camera carries them, and
//! a four-view run's records are the same whichever camera's frame is the world.
//!
//! Needs `../shared/data` and the MediaPipe weights (fetched with pip on first use): without
//! them the tests fail, they do not skip.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test is a panic

mod rig;

use monohand::{HandPipeline, Session, SessionOptions};
use monohand_core::prelude::*;
use monohand_io::jsonl::FrameRecord;
use monohand_testkit::TABLE_RIG_VIEWS;
use nalgebra::Vector3;
use rig::camera;
use std::sync::Arc;

/// Frames of each view the tests run (the hand is in view in all four from frame 13).
const FRAMES: std::ops::Range<usize> = 13..43;

/// The largest difference allowed, mm: the bound.
const TOLERANCE_MM: f64 = 0.01;

/// The records of a tracked run of `views` with `cameras`.
fn run(pipeline: &Arc<HandPipeline>, cameras: Vec<Camera>, views: &[&str]) -> Vec<FrameRecord> {
    rig::run(
        pipeline,
        cameras,
        views,
        FRAMES,
        monohand::Settings::default(),
    )
}

/// Every hand's 3D joints of `records` mapped by `to`, frame by frame.
fn joints(records: &[FrameRecord], to: &Extrinsics) -> Vec<Vec<[Vector3<f64>; NUM_JOINTS]>> {
    records
        .iter()
        .map(|r| {
            r.hands
                .iter()
                .filter_map(|h| h.joints_3d())
                .map(|j| j.map(|x| to.transform(&x)))
                .collect()
        })
        .collect()
}

/// The largest distance between the joints of two runs, which must have the same hands
/// with 3D in every frame, and enough of them.
fn largest_difference(
    a: &[Vec<[Vector3<f64>; NUM_JOINTS]>],
    b: &[Vec<[Vector3<f64>; NUM_JOINTS]>],
) -> f64 {
    assert_eq!(a.len(), FRAMES.len());
    assert_eq!(
        a.iter().map(Vec::len).collect::<Vec<_>>(),
        b.iter().map(Vec::len).collect::<Vec<_>>()
    );
    let fitted = a.iter().filter(|f| !f.is_empty()).count();
    assert!(
        fitted >= FRAMES.len() * 9 / 10,
        "{fitted} frames with a 3D hand"
    );
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).norm()))
        .fold(0.0, f64::max)
}

fn pipeline() -> Arc<HandPipeline> {
    Arc::new(Session::load_pipeline(&SessionOptions::default()).expect("networks"))
}

#[test]
fn a_mono_view_gives_the_same_hands_with_or_without_its_extrinsics() {
    let pipeline = pipeline();
    let view = TABLE_RIG_VIEWS[2];
    let placed = camera(view);
    assert!(!placed.extrinsics.is_identity(), "a view with extrinsics");
    let own = placed.with_extrinsics(Extrinsics::default());
    // The run with extrinsics is in the master camera's frame; the other in the view's.
    let in_master = run(&pipeline, vec![placed], &[view]);
    let in_view = run(&pipeline, vec![own], &[view]);
    let d = largest_difference(
        &joints(&in_master, &placed.extrinsics),
        &joints(&in_view, &Extrinsics::default()),
    );
    assert!(d < TOLERANCE_MM, "{d} mm apart");
}

#[test]
fn a_rig_gives_the_same_hands_whichever_camera_is_the_world() {
    let pipeline = pipeline();
    let cameras: Vec<Camera> = TABLE_RIG_VIEWS.iter().map(|v| camera(v)).collect();
    // The world moved to the third camera's frame: every camera maps from there.
    let world = cameras[2].extrinsics;
    let from_third = world.inverse();
    let moved: Vec<Camera> = cameras
        .iter()
        .map(|c| c.with_extrinsics(c.extrinsics.after(&from_third)))
        .collect();
    let in_master = run(&pipeline, cameras, &TABLE_RIG_VIEWS);
    let in_third = run(&pipeline, moved, &TABLE_RIG_VIEWS);
    // Both in the master's frame.
    let d = largest_difference(
        &joints(&in_master, &Extrinsics::default()),
        &joints(&in_third, &from_third),
    );
    assert!(d < TOLERANCE_MM, "{d} mm apart");
}
