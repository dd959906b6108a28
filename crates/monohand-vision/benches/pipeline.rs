//! Per-stage latency: decode, palm detection (preprocess + network), landmark crop, landmark
//! network, face detection, the whole pipeline on a still image and one tracked video frame
//! (with and without the palm detector), on `../shared/data/images/pinto/hand.png`.
//!
//! `*_network_tract_1x1`: the same network with tract's convolution for the 1x1 layers
//! instead of monohand's `PointwiseConv` (before/after in one session).
//!
//! Compare with LiteRT (1 thread) from `tools/litert_reference.py`, which prints its own
//! ms/inference for the same models, or run `bench/networks/run.sh` (both interleaved).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use monohand_vision::landmarks::{LandmarkModel, LandmarkOptions};
use monohand_vision::palm::{PalmDetector, PalmOptions};
use monohand_vision::tflite_import::ImportOptions;
use monohand_vision::{
    face::FaceDetector, image_io, HandPipeline, ModelFile, ModelOptions, ModelStore,
    PipelineOptions, RgbImage, TfliteNet,
};

fn net(store: &ModelStore, f: ModelFile) -> TfliteNet {
    TfliteNet::from_bytes(&store.load(f).expect("load"), &store.path_of(f)).expect("import")
}

/// The network with tract's own convolution for the 1x1 layers instead of
/// `tflite_import::PointwiseConv` (the state before it, for comparison in one session).
fn net_tract_1x1(store: &ModelStore, f: ModelFile) -> TfliteNet {
    let options = ImportOptions {
        fast_pointwise: false,
        ..ImportOptions::default()
    };
    TfliteNet::from_bytes_with(&store.load(f).expect("load"), &store.path_of(f), options)
        .expect("import")
}

/// One size's networks, stage by stage, on `img`.
fn bench_networks(
    c: &mut Criterion,
    store: &ModelStore,
    img: &RgbImage,
    name: &str,
    palm_file: ModelFile,
    lm_file: ModelFile,
) {
    let palm = PalmDetector::new(net(store, palm_file), PalmOptions::default()).expect("palm");
    let lm = LandmarkModel::new(net(store, lm_file), LandmarkOptions::default()).expect("lm");
    let palm_net = net(store, palm_file);
    let lm_net = net(store, lm_file);
    let palm_net_tract = net_tract_1x1(store, palm_file);
    let lm_net_tract = net_tract_1x1(store, lm_file);
    let detections = palm.detect(img).expect("detect");
    let roi = detections.first().expect("a palm in hand.png").hand_roi();
    c.bench_function(&format!("palm_{name}_preprocess"), |b| {
        b.iter(|| palm.preprocess(img).expect("pre"))
    });
    c.bench_function(&format!("palm_{name}_network"), |b| {
        b.iter(|| {
            palm_net
                .run(palm_net.input_tensor().expect("t"))
                .expect("run")
        })
    });
    c.bench_function(&format!("palm_{name}_network_tract_1x1"), |b| {
        b.iter(|| {
            palm_net_tract
                .run(palm_net_tract.input_tensor().expect("t"))
                .expect("run")
        })
    });
    c.bench_function(&format!("palm_{name}_detect_total"), |b| {
        b.iter(|| palm.detect(img).expect("detect"))
    });
    c.bench_function(&format!("landmark_{name}_crop"), |b| {
        b.iter(|| lm.preprocess(img, &roi).expect("crop"))
    });
    c.bench_function(&format!("landmark_{name}_network"), |b| {
        b.iter(|| lm_net.run(lm_net.input_tensor().expect("t")).expect("run"))
    });
    c.bench_function(&format!("landmark_{name}_network_tract_1x1"), |b| {
        b.iter(|| {
            lm_net_tract
                .run(lm_net_tract.input_tensor().expect("t"))
                .expect("run")
        })
    });
}

fn stages(c: &mut Criterion) {
    let image = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/images/pinto/hand.png");
    if !image.exists() {
        eprintln!("SKIP: {} not found", image.display());
        return;
    }
    let store = match ModelStore::new(None).and_then(|s| s.fetch().map(|_| s)) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("SKIP: models unavailable: {e}");
            return;
        }
    };
    let bytes = std::fs::read(&image).expect("read");
    let img = image_io::decode_rgb(&bytes, "hand.png").expect("decode");
    c.bench_function("decode_png_640x480", |b| {
        b.iter(|| image_io::decode_rgb(&bytes, "hand.png").expect("decode"))
    });

    for (name, palm_file, lm_file) in [
        (
            "full",
            ModelFile::PalmDetectionFull,
            ModelFile::HandLandmarkFull,
        ),
        (
            "lite",
            ModelFile::PalmDetectionLite,
            ModelFile::HandLandmarkLite,
        ),
    ] {
        bench_networks(c, &store, &img, name, palm_file, lm_file);
    }
    let face = FaceDetector::new(net(&store, ModelFile::FaceDetectionShortRange)).expect("face");
    c.bench_function("face_detect_total", |b| {
        b.iter(|| face.detect(&img).expect("face"))
    });
    let pipeline = HandPipeline::new(
        &ModelOptions::default(),
        PipelineOptions {
            refine_passes: 0,
            ..Default::default()
        },
    )
    .expect("pipeline");
    c.bench_function("pipeline_full_single_pass", |b| {
        b.iter(|| pipeline.detect(&img).expect("detect"))
    });
    // One video frame as `monohand run` processes it: the landmark network in the crop
    // predicted by the previous frame's keypoints, without / with the palm detector (and
    // the landmark network on its regions, and the face detector if loaded).
    let previous = pipeline.detect(&img).expect("detect").hands;
    assert!(!previous.is_empty(), "a hand in hand.png");
    c.bench_function("pipeline_full_track_frame", |b| {
        b.iter(|| pipeline.track(&img, &previous, false).expect("track"))
    });
    c.bench_function("pipeline_full_track_and_detect_frame", |b| {
        b.iter(|| pipeline.track(&img, &previous, true).expect("track"))
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(4));
    targets = stages
}
criterion_main!(benches);
