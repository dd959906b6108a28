//! Cost of converting one decoded 4:2:0 frame to RGB (`video::yuv420_to_rgb`, what the video
//! reader's thread does per frame of 8-bit 4:2:0 video) at 1920x1080 and 3840x2160.
//! `cargo bench -p monohand-media --bench yuv`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed bench is a panic

use criterion::{criterion_group, criterion_main, Criterion};
use monohand_media::video::{yuv420_frame_len, yuv420_to_rgb, Yuv420, YuvMatrix};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let layout = Yuv420 {
        matrix: YuvMatrix::Bt709,
        full_range: false,
    };
    for (w, h) in [(640, 480), (1920, 1080), (3840, 2160)] {
        // Smooth content (a gradient), as decoded video is; the cost does not depend on it.
        let planes: Vec<u8> = (0..yuv420_frame_len(w, h))
            .map(|i| (i % 251) as u8)
            .collect();
        let mut rgb = vec![0u8; w * h * 3];
        c.bench_function(&format!("yuv420_to_rgb {w}x{h}"), |b| {
            b.iter(|| assert!(yuv420_to_rgb(black_box(&planes), (w, h), layout, &mut rgb)))
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
