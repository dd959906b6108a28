//! Prints what the pipeline finds in images and optionally writes overlays.
//!
//! `cargo run --release -p monohand-vision --example detect -- [--overlay DIR] IMAGE...`
#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed test or bench is a panic

use std::path::PathBuf;

use monohand_vision::{image_io, HandPipeline, ModelOptions, PipelineOptions};

/// The image with the hands' keypoints (wrist red, thumb yellow, the rest green), their
/// boxes' corners (blue) and the heads' boxes (magenta) drawn on it.
fn drawn(img: &image::RgbImage, found: &monohand_vision::Detections) -> image::RgbImage {
    let mut out = img.clone();
    let mut dot = |x: f64, y: f64, r: i64, c: [u8; 3]| {
        for dy in -r..=r {
            for dx in -r..=r {
                let (px, py) = (x.round() as i64 + dx, y.round() as i64 + dy);
                if px >= 0 && py >= 0 && (px as u32) < out.width() && (py as u32) < out.height() {
                    out.put_pixel(px as u32, py as u32, image::Rgb(c));
                }
            }
        }
    };
    let r = (img.width().max(img.height()) / 300).max(1) as i64;
    for h in &found.hands {
        for (j, p) in h.keypoints.points.iter().enumerate() {
            let c = if j == 0 {
                [255, 0, 0]
            } else if j <= 4 {
                [255, 255, 0]
            } else {
                [0, 255, 0]
            };
            dot(p[0], p[1], r, c);
        }
        for c in h.oriented_box.corners() {
            dot(c[0], c[1], r * 2, [0, 0, 255]);
        }
    }
    for h in &found.heads {
        let b = h.head_box.to_array();
        for t in 0..=20 {
            let f = t as f64 / 20.0;
            dot(b[0] + f * (b[2] - b[0]), b[1], r, [255, 0, 255]);
            dot(b[0] + f * (b[2] - b[0]), b[3], r, [255, 0, 255]);
            dot(b[0], b[1] + f * (b[3] - b[1]), r, [255, 0, 255]);
            dot(b[2], b[1] + f * (b[3] - b[1]), r, [255, 0, 255]);
        }
    }
    out
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let overlay = match args.iter().position(|a| a == "--overlay") {
        Some(i) => {
            let dir = PathBuf::from(args.remove(i + 1));
            args.remove(i);
            std::fs::create_dir_all(&dir)?;
            Some(dir)
        }
        None => None,
    };
    let t0 = std::time::Instant::now();
    let pipeline = HandPipeline::new(
        &ModelOptions {
            detect_heads: true,
            ..Default::default()
        },
        PipelineOptions::default(),
    )?;
    eprintln!(
        "pipeline ready in {:.0} ms (import + optimise 3 networks)",
        t0.elapsed().as_secs_f64() * 1e3
    );
    for path in args {
        let path = PathBuf::from(path);
        let img = match image_io::load_rgb(&path) {
            Ok(i) => i,
            Err(e) => {
                println!("{}: error: {e}", path.display());
                continue;
            }
        };
        let t = std::time::Instant::now();
        let found = pipeline.detect(&img)?;
        println!(
            "{}: {}x{} {} hands, {} heads ({:.1} ms)",
            path.display(),
            img.width(),
            img.height(),
            found.hands.len(),
            found.heads.len(),
            t.elapsed().as_secs_f64() * 1e3
        );
        for h in &found.hands {
            let b = h.keypoints.bounds().to_array();
            let conf: Vec<String> = h
                .keypoints
                .points
                .iter()
                .map(|p| format!("{:.2}", p[2]))
                .collect();
            println!(
                "  hand det {:.3} presence {:.3} {:?} {:.3} bounds [{:.0} {:.0} {:.0} {:.0}] rot {:.0}deg conf [{}]",
                h.detection_score, h.presence, h.side, h.side_score, b[0], b[1], b[2], b[3], h.roi.rotation.to_degrees(), conf.join(" ")
            );
        }
        for h in &found.heads {
            println!(
                "  head {:.3} [{:.0} {:.0} {:.0} {:.0}]",
                h.score, h.head_box.x_min, h.head_box.y_min, h.head_box.x_max, h.head_box.y_max
            );
        }
        if let Some(dir) = &overlay {
            let out = drawn(&img, &found);
            let name = path.to_string_lossy().replace('/', "_");
            out.save(dir.join(format!("{name}.png")))?;
        }
    }
    Ok(())
}
