//! A calibration's outputs: the camera files (the project's JSON, OpenCV YAML), the
//! report for the user (text and Markdown) and its picture of where the corners were seen
//! with the lens's distortion field.

use super::{Calibrated, CameraViews};
use monohand_calib::calibrate::CameraCalibration;
use monohand_core::camera::{Camera, LensModel};
use monohand_io::calibration::{CalibrationInfo, CameraStd};
use monohand_media::overlay::{draw_label, draw_line, fill_circle, fill_rect, Pen};
use monohand_vision::RgbImage;
use nalgebra::Vector2;

/// The distance at which the report states what the focal length's uncertainty means for
/// a hand's depth, millimetres (a hand at arm's length from a webcam).
pub const HAND_DEPTH_MM: f64 = 500.0;

/// Now, as ISO 8601 UTC (`2026-11-27T06:12:00Z`).
pub fn date_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Days since 1970-01-01 to a civil date (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// What camera `k`'s calibration says about itself, for its file.
pub fn camera_info(c: &Calibrated, k: usize, date: &str) -> CalibrationInfo {
    let cam = &c.cameras[k];
    let n = dist_len(&cam.camera);
    CalibrationInfo {
        rms_px: cam.rms_px,
        views: cam.used_views(),
        board_cols: c.board.cols,
        board_rows: c.board.rows,
        square_mm: c.board.square_mm,
        date: date.to_string(),
        std: Some(CameraStd {
            fx: cam.std.fx,
            fy: cam.std.fy,
            cx: cam.std.cx,
            cy: cam.std.cy,
            dist: cam.std.distortion[..n].to_vec(),
        }),
    }
}

/// The number of distortion coefficients the camera's JSON writes (a fisheye's 4; the
/// pinhole's 0, 5 or 8).
fn dist_len(camera: &Camera) -> usize {
    let c = camera.distortion.coeffs;
    if camera.distortion.model == LensModel::Fisheye {
        4
    } else if c[5..].iter().any(|&v| v != 0.0) {
        8
    } else if c[4] != 0.0 || c[..4].iter().any(|&v| v != 0.0) {
        5
    } else {
        0
    }
}

/// The camera's lens model as the report names it: `fisheye (k1..k4)`, or the pinhole's
/// `pinhole (k1 k2 p1 p2 k3)` / `pinhole (rational, k1..k6)`.
fn model_name(camera: &Camera) -> &'static str {
    match (camera.distortion.model, dist_len(camera)) {
        (LensModel::Fisheye, _) => "fisheye (k1..k4)",
        (LensModel::Pinhole, 8) => "pinhole (rational, k1 k2 p1 p2 k3 k4 k5 k6)",
        (LensModel::Pinhole, _) => "pinhole (k1 k2 p1 p2 k3)",
    }
}

/// One standard deviation of a hand's depth at `z_mm` from the focal length's
/// uncertainty alone (depth scales with the focal length).
pub fn depth_std_mm(cam: &CameraCalibration, z_mm: f64) -> f64 {
    let k = &cam.camera.intrinsics;
    z_mm * 0.5 * (cam.std.fx / k.fx + cam.std.fy / k.fy)
}

/// The report of a calibration, as Markdown: per camera the RMS, the numbers with their
/// uncertainty and what it means for a hand's depth, the warnings, every view's error or
/// why it was not used, and (when `pictures` names them) the coverage picture; for a rig
/// the poses between the cameras.
pub fn markdown_report(c: &Calibrated, pictures: &[String]) -> String {
    let b = &c.board;
    let mut out = format!(
        "# Camera calibration\n\nBoard: {}x{} inner corners, {} mm squares.\n",
        b.cols, b.rows, b.square_mm
    );
    for (k, (cam, views)) in c.cameras.iter().zip(&c.views).enumerate() {
        out.push_str(&camera_section(k, cam, views, c.cameras.len() > 1));
        if let Some(p) = pictures.get(k) {
            out.push_str(&format!(
                "\n![where the corners were seen, and the distortion]({p})\n\n\
                 Dots: the corners of the views used; shaded cells: parts of the image where no \
                 corner was seen; arrows: where a distortion-free camera would see each point \
                 (lengthened as the picture says).\n"
            ));
        }
    }
    if let Some(rig) = &c.rig {
        out.push_str(&format!(
            "\n## The rig\n\nJoint RMS reprojection error: {:.3} px.\n\n| camera | R (rotation vector, degrees) | t (mm) | baseline (mm) | instants shared |\n|---|---|---|---|---|\n",
            rig.rms_px
        ));
        for (k, cam) in rig.cameras.iter().enumerate() {
            let e = &cam.camera.extrinsics;
            let r = e.rotation.scaled_axis().map(f64::to_degrees);
            let t = e.translation;
            let shared = if k == 0 {
                "-".to_string()
            } else {
                rig.shared_views
                    .get(k - 1)
                    .map_or("-".into(), |n| n.to_string())
            };
            out.push_str(&format!(
                "| {k} | [{:.3}, {:.3}, {:.3}] | [{:.2}, {:.2}, {:.2}] | {:.2} | {shared} |\n",
                r.x,
                r.y,
                r.z,
                t.x,
                t.y,
                t.z,
                t.norm()
            ));
        }
    }
    out
}

fn camera_section(k: usize, cam: &CameraCalibration, views: &CameraViews, rig: bool) -> String {
    let i = &cam.camera.intrinsics;
    let s = &cam.std;
    let title = if rig {
        format!("\n## Camera {k}: {}\n\n", views.input)
    } else {
        format!("\n## {}\n\n", views.input)
    };
    let mut out = title;
    out.push_str(&format!(
        "{}x{} pixels, the {} model; {} views used of {} frames examined; RMS reprojection error **{:.3} px**.\n\n\
         | | value | one standard deviation |\n|---|---|---|\n\
         | fx | {:.2} | {:.2} |\n| fy | {:.2} | {:.2} |\n| cx | {:.2} | {:.2} |\n| cy | {:.2} | {:.2} |\n",
        i.width, i.height, model_name(&cam.camera), cam.used_views(), views.frames, cam.rms_px,
        i.fx, s.fx, i.fy, s.fy, i.cx, s.cx, i.cy, s.cy
    ));
    let names: &[&str] = match cam.camera.distortion.model {
        LensModel::Pinhole => &["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"],
        LensModel::Fisheye => &["k1", "k2", "k3", "k4"],
    };
    for (j, name) in names.iter().enumerate().take(dist_len(&cam.camera)) {
        out.push_str(&format!(
            "| {name} | {:.5} | {:.5} |\n",
            cam.camera.distortion.coeffs[j], s.distortion[j]
        ));
    }
    out.push_str(&format!(
        "\nWhat this means for a hand: depth scales with the focal length, so a hand at {:.1} m \
         is placed within ±{:.1} mm in depth (one standard deviation) from this calibration's \
         focal length alone.\n",
        HAND_DEPTH_MM / 1000.0,
        depth_std_mm(cam, HAND_DEPTH_MM)
    ));
    if !cam.warnings.is_empty() {
        out.push_str("\n**Warnings**\n\n");
        for w in &cam.warnings {
            out.push_str(&format!("- {w}\n"));
        }
    }
    out.push_str("\n| view | RMS (px) | used |\n|---|---|---|\n");
    for v in &cam.views {
        let used = v
            .dropped
            .as_deref()
            .map_or("yes".to_string(), |why| format!("no: {why}"));
        out.push_str(&format!("| {} | {:.3} | {used} |\n", v.name, v.rms_px));
    }
    for (name, why) in &views.skipped {
        out.push_str(&format!("| {name} | - | no: {why} |\n"));
    }
    out
}

/// Camera `k`'s picture: the image's area, shaded where no corner was seen, the corners of
/// the views used as dots, and the distortion field as arrows from where the lens puts a
/// point to where a distortion-free camera would (lengthened so that the longest is about
/// a grid cell; the factor is written in the picture).
pub fn picture(c: &Calibrated, k: usize) -> RgbImage {
    let cam = &c.cameras[k];
    let views = &c.views[k];
    let (w, h) = (cam.camera.intrinsics.width, cam.camera.intrinsics.height);
    let (w, h) = (w.max(1), h.max(1));
    let grey = vec![40u8; w as usize * h as usize * 3];
    let mut img = RgbImage::from_raw(w, h, grey).unwrap_or_else(|| RgbImage::new(w, h));
    let cov = &views.coverage;
    let (cw, ch) = (w as f64 / cov.cols as f64, h as f64 / cov.rows as f64);
    for r in 0..cov.rows {
        for col in 0..cov.cols {
            if cov.hits[r * cov.cols + col] == 0 {
                let bbox = monohand_core::bbox::BBox::new(
                    col as f64 * cw,
                    r as f64 * ch,
                    (col + 1) as f64 * cw,
                    (r + 1) as f64 * ch,
                );
                fill_rect(&mut img, bbox, [150, 40, 40], 0.5);
            }
        }
    }
    let dot = (w.max(h) as f64 / 400.0).max(1.5);
    for (v, result) in views.views.iter().zip(cam.views.iter()) {
        let color = if result.dropped.is_some() {
            [255, 80, 80]
        } else {
            [120, 220, 120]
        };
        for p in &v.corners {
            fill_circle(&mut img, [p.x, p.y], dot, &Pen::new(color, 1.0));
        }
    }
    let gain = draw_distortion(&mut img, &cam.camera, cw.min(ch));
    let text = format!(
        "RMS {:.2} PX  {} VIEWS  COVERAGE {:.0}%  ARROWS X{gain:.0}",
        cam.rms_px,
        cam.used_views(),
        cov.fraction() * 100.0
    );
    let scale = ((w.max(h) as f64 / 640.0).round() as usize).max(1);
    draw_label(
        &mut img,
        &text,
        [4.0, 4.0],
        scale,
        [255, 255, 255],
        [0, 0, 0],
    );
    img
}

/// Draws the distortion field on a 16-column grid; returns the lengthening used.
fn draw_distortion(img: &mut RgbImage, camera: &Camera, cell: f64) -> f64 {
    let k = &camera.intrinsics;
    let (w, h) = (k.width as f64, k.height as f64);
    let step = w / 16.0;
    let mut arrows = Vec::new();
    let mut y = step / 2.0;
    while y < h {
        let mut x = step / 2.0;
        while x < w {
            let n = Vector2::new((x - k.cx) / k.fx, (y - k.cy) / k.fy);
            // (A calibration's lens is the pinhole's, whose every point has a pinhole point.)
            if let Some(u) = camera.distortion.undistort(n) {
                let ideal = [k.cx + k.fx * u.x, k.cy + k.fy * u.y];
                arrows.push(([x, y], [ideal[0] - x, ideal[1] - y]));
            }
            x += step;
        }
        y += step;
    }
    let longest = arrows
        .iter()
        .map(|(_, d)| d[0].hypot(d[1]))
        .filter(|l| l.is_finite())
        .fold(0.0, f64::max);
    let gain = if longest > 0.0 {
        (cell / longest).clamp(1.0, 100.0).floor()
    } else {
        1.0
    };
    let pen = Pen::new([255, 210, 60], 1.5);
    for (p, d) in arrows {
        if !(d[0].is_finite() && d[1].is_finite()) {
            continue;
        }
        let q = [p[0] + gain * d[0], p[1] + gain * d[1]];
        draw_line(img, p, q, &pen);
        fill_circle(img, q, 2.0, &pen);
    }
    gain
}

/// The report's text for the terminal: per camera one line of numbers and its warnings.
pub fn summary(c: &Calibrated) -> String {
    let mut out = String::new();
    for (k, cam) in c.cameras.iter().enumerate() {
        let i = &cam.camera.intrinsics;
        let s = &cam.std;
        out.push_str(&format!(
            "camera {k} ({}): {}, {} views, RMS {:.3} px; fx {:.2} ± {:.2}, fy {:.2} ± {:.2}, cx {:.2} ± {:.2}, cy {:.2} ± {:.2} px; a hand at {:.1} m is ±{:.1} mm in depth from the focal length\n",
            c.views[k].input,
            model_name(&cam.camera),
            cam.used_views(),
            cam.rms_px,
            i.fx, s.fx, i.fy, s.fy, i.cx, s.cx, i.cy, s.cy,
            HAND_DEPTH_MM / 1000.0,
            depth_std_mm(cam, HAND_DEPTH_MM)
        ));
        for v in &cam.views {
            if let Some(why) = &v.dropped {
                out.push_str(&format!("  view {} dropped: {why}\n", v.name));
            }
        }
        for w in &cam.warnings {
            out.push_str(&format!("  warning: {w}\n"));
        }
    }
    if let Some(rig) = &c.rig {
        for (k, cam) in rig.cameras.iter().enumerate().skip(1) {
            let e = &cam.camera.extrinsics;
            out.push_str(&format!(
                "camera {k} from camera 0: rotation {:.3} degrees, baseline {:.2} mm (t = [{:.2}, {:.2}, {:.2}]); rig RMS {:.3} px\n",
                e.rotation.angle().to_degrees(),
                e.translation.norm(),
                e.translation.x,
                e.translation.y,
                e.translation.z,
                rig.rms_px
            ));
        }
    }
    out
}

/// Draws what the calibration sees in a frame, for a live window: the board's corners
/// (green when the frame was kept as a view, yellow when seen but not kept), the image's
/// cells that no kept view has covered yet (shaded red), and a status line: the views
/// kept, the coverage, and why the frame was not kept.
pub fn draw_seen(frame: &mut RgbImage, seen: &super::SeenFrame<'_>) {
    let cov = seen.coverage;
    let (w, h) = frame.dimensions();
    if (cov.width, cov.height) == (w, h) {
        let (cw, ch) = (w as f64 / cov.cols as f64, h as f64 / cov.rows as f64);
        for (i, &n) in cov.hits.iter().enumerate() {
            if n == 0 {
                let (r, c) = ((i / cov.cols) as f64, (i % cov.cols) as f64);
                let bbox =
                    monohand_core::bbox::BBox::new(c * cw, r * ch, (c + 1.0) * cw, (r + 1.0) * ch);
                fill_rect(frame, bbox, [200, 40, 40], 0.25);
            }
        }
    }
    if let Some(corners) = seen.corners {
        let color = if seen.kept {
            [60, 230, 60]
        } else {
            [240, 210, 40]
        };
        let pen = Pen::new(color, 2.0);
        for pair in corners.windows(2) {
            draw_line(frame, [pair[0].x, pair[0].y], [pair[1].x, pair[1].y], &pen);
        }
        for p in corners {
            fill_circle(frame, [p.x, p.y], 3.0, &pen);
        }
    }
    let mut status = format!(
        "VIEWS {}/{}  COVERAGE {:.0}%",
        seen.views,
        seen.views_wanted,
        cov.fraction() * 100.0
    );
    if seen.kept {
        status.push_str("  KEPT");
    } else if let Some(why) = seen.why_not {
        status.push_str(&format!("  {}", why.to_uppercase()));
    }
    let scale = ((w.max(h) as f64 / 640.0).round() as usize).max(1);
    draw_label(
        frame,
        &status,
        [4.0, 4.0],
        scale,
        [255, 255, 255],
        [0, 0, 0],
    );
}
