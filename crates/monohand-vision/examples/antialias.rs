//! How close the shrinking crop warps come to the exact area average (issue 34).
//!
//! For each photo and footprint (image pixels per output pixel), a 224-pixel crop turned by
//! 0.4 rad about the photo's centre is made four ways: plain bilinear (no anti-aliasing),
//! the old supersampling (`warp_into_supersampled`, n x n samples), the box reduction the
//! pipeline now uses (`warp_into_with_border`), and the reference, each output pixel the
//! mean of the photo over its footprint (32 x 32 point samples of the photo's pixels per
//! output pixel, which tends to the exact area average). Prints the mean absolute
//! difference from the reference in 8-bit levels, and the time of each warp.
//!
//! `cargo run --release -p monohand-vision --example antialias -- PHOTO...`

use std::time::Instant;

use monohand_vision::geometry::RotatedRect;
use monohand_vision::warp::{
    warp_into_supersampled, warp_into_with_border, Border, Normalization, PLAIN_BILINEAR_UP_TO,
};

const SIZE: usize = 224;

fn reference(img: &image::RgbImage, m: &[[f64; 3]; 2], n: usize) -> Vec<f32> {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let mut out = vec![0f32; SIZE * SIZE * 3];
    for row in 0..SIZE {
        for col in 0..SIZE {
            let mut acc = [0f64; 3];
            for k in 0..n * n {
                let u = col as f64 + ((k % n) as f64 + 0.5) / n as f64;
                let v = row as f64 + ((k / n) as f64 + 0.5) / n as f64;
                let x = (m[0][0] * u + m[0][1] * v + m[0][2]).floor() as i64;
                let y = (m[1][0] * u + m[1][1] * v + m[1][2]).floor() as i64;
                // The replicated border, as the landmark crop reads it.
                let p = img.get_pixel(x.clamp(0, w - 1) as u32, y.clamp(0, h - 1) as u32);
                for c in 0..3 {
                    acc[c] += p[c] as f64;
                }
            }
            for c in 0..3 {
                out[(row * SIZE + col) * 3 + c] = (acc[c] / (n * n) as f64) as f32;
            }
        }
    }
    out
}

fn mean_abs(a: &[f32], b: &[f32]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() as f64)
        .sum::<f64>()
        / a.len() as f64
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let norm = Normalization {
        scale: 1.0,
        offset: 0.0,
    };
    println!("| photo | footprint | plain bilinear | old supersampling (n x n) | box reduction (new) | old ms | new ms |");
    println!("|---|---|---|---|---|---|---|");
    for path in std::env::args().skip(1) {
        let img = image::open(&path)?.to_rgb8();
        let name = std::path::Path::new(&path)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let (w, h) = (img.width() as f64, img.height() as f64);
        for footprint in [1.5, 2.5, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0] {
            let side = footprint * SIZE as f64;
            if side > 1.5 * w.max(h) {
                continue;
            }
            let roi = RotatedRect {
                center: [w / 2.0, h / 2.0],
                width: side,
                height: side,
                rotation: 0.4,
            };
            let m = roi.crop_to_image(SIZE, SIZE);
            let warp = |f: fn(
                &image::RgbImage,
                &monohand_vision::geometry::Affine2,
                usize,
                usize,
                Normalization,
                Border,
                &mut [f32],
            )| {
                let mut out = vec![0f32; SIZE * SIZE * 3];
                let mut best = f64::INFINITY;
                for _ in 0..5 {
                    let t = Instant::now();
                    f(&img, &m, SIZE, SIZE, norm, Border::Replicate, &mut out);
                    best = best.min(t.elapsed().as_secs_f64() * 1e3);
                }
                (out, best)
            };
            let (old, old_ms) = warp(warp_into_supersampled);
            let (new, new_ms) = warp(warp_into_with_border);
            // Plain bilinear: one sample per output pixel.
            let mut plain = vec![0f32; SIZE * SIZE * 3];
            plain_bilinear(&img, &m, &mut plain);
            let reference = reference(&img, &m.0, 32);
            let n = if footprint > PLAIN_BILINEAR_UP_TO {
                (footprint.round() as usize).clamp(2, 8)
            } else {
                1
            };
            println!(
                "| {name} ({}x{}) | {footprint} | {:.2} | {:.2} ({n}x{n}) | {:.2} | {old_ms:.2} | {new_ms:.2} |",
                img.width(),
                img.height(),
                mean_abs(&plain, &reference),
                mean_abs(&old, &reference),
                mean_abs(&new, &reference),
            );
        }
    }
    Ok(())
}

/// One bilinear sample per output pixel (replicated border), no anti-aliasing.
fn plain_bilinear(img: &image::RgbImage, m: &monohand_vision::geometry::Affine2, out: &mut [f32]) {
    let (w, h) = (img.width() as f64, img.height() as f64);
    for row in 0..SIZE {
        for col in 0..SIZE {
            let (u, v) = (col as f64 + 0.5, row as f64 + 0.5);
            let x = (m.0[0][0] * u + m.0[0][1] * v + m.0[0][2]).clamp(0.5, w - 0.5) - 0.5;
            let y = (m.0[1][0] * u + m.0[1][1] * v + m.0[1][2]).clamp(0.5, h - 0.5) - 0.5;
            let (x0, y0) = (x.floor(), y.floor());
            let (ax, ay) = (x - x0, y - y0);
            let px = |xi: f64, yi: f64, c: usize| {
                img.get_pixel(xi.min(w - 1.0) as u32, yi.min(h - 1.0) as u32)[c] as f64
            };
            for c in 0..3 {
                let t = px(x0, y0, c) * (1.0 - ax) + px(x0 + 1.0, y0, c) * ax;
                let b = px(x0, y0 + 1.0, c) * (1.0 - ax) + px(x0 + 1.0, y0 + 1.0, c) * ax;
                out[(row * SIZE + col) * 3 + c] = (t * (1.0 - ay) + b * ay) as f32;
            }
        }
    }
}
