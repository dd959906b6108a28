//! Saddle-point candidates: the ChESS corner response (Bennett and Lasenby, "ChESS - Quick
//! and Robust Detection of Chess-board Features", 2014) on a smoothed pyramid level, its
//! local maxima, to a tenth of a pixel by a quadratic fit.

use super::plane::Plane;
use nalgebra::Vector2;

/// Radius of the ring of samples, pixels of the detection level.
pub(crate) const RING_RADIUS: usize = 5;

/// The 16 samples of the ring, in angle order.
const RING: [(isize, isize); 16] = [
    (5, 0),
    (5, 2),
    (4, 4),
    (2, 5),
    (0, 5),
    (-2, 5),
    (-4, 4),
    (-5, 2),
    (-5, 0),
    (-5, -2),
    (-4, -4),
    (-2, -5),
    (0, -5),
    (2, -5),
    (4, -4),
    (5, -2),
];

/// A saddle candidate.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Candidate {
    pub p: Vector2<f64>,
    pub response: f32,
}

/// The ChESS response of every pixel (zero within the ring's radius of the border):
/// about 8 times the contrast at an ideal X corner, negative at edges and blobs.
pub(crate) fn chess_response(img: &Plane) -> Plane {
    let (w, h) = (img.w, img.h);
    let mut out = vec![0.0f32; w * h];
    let r = RING_RADIUS;
    if w <= 2 * r + 1 || h <= 2 * r + 1 {
        return Plane { w, h, data: out };
    }
    // Row by row, each term a pass over the row's pixels (vectorizable).
    let len = w - 2 * r;
    let d = &img.data;
    let mut pair = vec![vec![0.0f32; len]; 8]; // s[n] + s[n + 8]
    let mut acc = vec![0.0f32; len];
    let mut diff = vec![0.0f32; len];
    for y in r..h - r {
        let ring = |n: usize| {
            let (dx, dy) = RING[n];
            let start = ((y as isize + dy) * w as isize + r as isize + dx) as usize;
            &d[start..start + len]
        };
        diff.fill(0.0);
        for (n, p) in pair.iter_mut().enumerate() {
            let (a, b) = (ring(n), ring(n + 8));
            for (((p, a), b), e) in p.iter_mut().zip(a).zip(b).zip(diff.iter_mut()) {
                *p = a + b;
                *e += (a - b).abs();
            }
        }
        // Sum response minus difference response.
        acc.fill(0.0);
        for n in 0..4 {
            let (a, b) = (&pair[n], &pair[n + 4]);
            for ((o, a), b) in acc.iter_mut().zip(a).zip(b) {
                *o += (a - b).abs();
            }
        }
        // Minus 16 times the difference of the ring's mean and the local mean.
        let centre = &d[y * w + r..y * w + r + len];
        let left = &d[y * w + r - 1..y * w + r - 1 + len];
        let right = &d[y * w + r + 1..y * w + r + 1 + len];
        let up = &d[(y - 1) * w + r..(y - 1) * w + r + len];
        let down = &d[(y + 1) * w + r..(y + 1) * w + r + len];
        let out_row = &mut out[y * w + r..y * w + r + len];
        for x in 0..len {
            let ring_sum = pair[0][x]
                + pair[1][x]
                + pair[2][x]
                + pair[3][x]
                + pair[4][x]
                + pair[5][x]
                + pair[6][x]
                + pair[7][x];
            let local = (centre[x] + left[x] + right[x] + up[x] + down[x]) / 5.0;
            out_row[x] = acc[x] - diff[x] - 16.0 * (ring_sum / 16.0 - local).abs();
        }
    }
    Plane { w, h, data: out }
}

/// Local maxima of the response above `threshold` (strict over a (2*nms+1)^2 window, ties
/// to the first in raster order), strongest first, at most `max_count`.
pub(crate) fn candidates(
    response: &Plane,
    threshold: f32,
    nms: usize,
    max_count: usize,
) -> Vec<Candidate> {
    let (w, h) = (response.w, response.h);
    let mut out = Vec::new();
    let m = RING_RADIUS;
    if w <= 2 * m + 2 || h <= 2 * m + 2 {
        return out;
    }
    for y in m..h - m {
        for x in m..w - m {
            let v = response.at(x, y);
            if v <= threshold {
                continue;
            }
            let mut is_max = true;
            'window: for yy in y.saturating_sub(nms)..(y + nms + 1).min(h) {
                for xx in x.saturating_sub(nms)..(x + nms + 1).min(w) {
                    let u = response.at(xx, yy);
                    let earlier = (yy, xx) < (y, x);
                    if u > v || (u == v && earlier) {
                        is_max = false;
                        break 'window;
                    }
                }
            }
            if !is_max {
                continue;
            }
            let fit = |a: f32, b: f32, c: f32| {
                let den = a - 2.0 * b + c;
                if den < 0.0 {
                    (0.5 * (a - c) / den).clamp(-0.5, 0.5) as f64
                } else {
                    0.0
                }
            };
            let dx = fit(response.at(x - 1, y), v, response.at(x + 1, y));
            let dy = fit(response.at(x, y - 1), v, response.at(x, y + 1));
            out.push(Candidate {
                p: Vector2::new(x as f64 + dx, y as f64 + dy),
                response: v,
            });
        }
    }
    out.sort_by(|a, b| b.response.total_cmp(&a.response));
    out.truncate(max_count);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2x2 checker around (cx, cy), dark top-left and bottom-right.
    fn x_corner(w: usize, h: usize, cx: f64, cy: f64) -> Plane {
        let mut data = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let dark = ((x as f64) < cx) == ((y as f64) < cy);
                data.push(if dark { 30.0 } else { 220.0 });
            }
        }
        Plane { w, h, data }
    }

    #[test]
    fn an_x_corner_is_the_strongest_response() {
        let img = x_corner(40, 30, 20.5, 14.5).gaussian(1.0);
        let r = chess_response(&img);
        let c = candidates(&r, 50.0, 3, 10);
        assert!(!c.is_empty());
        assert!(
            (c[0].p - Vector2::new(20.5, 14.5)).norm() < 0.6,
            "{:?}",
            c[0]
        );
        assert!(c[0].response > 8.0 * 190.0 * 0.3, "{}", c[0].response);
    }

    #[test]
    fn an_edge_has_no_candidate() {
        let mut img = x_corner(40, 30, 20.5, -10.0);
        img = img.gaussian(1.0);
        let r = chess_response(&img);
        assert!(candidates(&r, 50.0, 3, 10).is_empty());
    }

    #[test]
    fn tiny_planes_have_no_candidates() {
        let img = Plane {
            w: 5,
            h: 5,
            data: vec![0.0; 25],
        };
        assert!(candidates(&chess_response(&img), 0.0, 3, 10).is_empty());
    }
}
