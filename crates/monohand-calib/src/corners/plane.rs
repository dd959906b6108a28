//! A float grey image (one level of the detection pyramid) and its sampling.

use crate::image::GrayImage;

/// A grey image of `f32` grey levels, row-major, tightly packed.
#[derive(Debug, Clone)]
pub(crate) struct Plane {
    pub w: usize,
    pub h: usize,
    pub data: Vec<f32>,
}

impl Plane {
    /// A copy of `image`; `None` if its fields do not describe its buffer (the fields are
    /// public, so a `GrayImage` may have been built without [`GrayImage::new`]'s checks).
    pub fn from_gray(image: &GrayImage<'_>) -> Option<Plane> {
        if !gray_is_valid(image) {
            return None;
        }
        let mut data = Vec::with_capacity(image.width * image.height);
        for y in 0..image.height {
            let row = image
                .data
                .get(y * image.stride..y * image.stride + image.width)?;
            data.extend(row.iter().map(|&v| v as f32));
        }
        Some(Plane {
            w: image.width,
            h: image.height,
            data,
        })
    }

    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.w + x]
    }

    /// Bilinear interpolation, pixel centres at integer coordinates, the border replicated.
    pub fn sample(&self, x: f64, y: f64) -> f64 {
        let fx = if x.is_finite() { x } else { 0.0 };
        let fy = if y.is_finite() { y } else { 0.0 };
        let fx = fx.clamp(0.0, (self.w - 1) as f64);
        let fy = fy.clamp(0.0, (self.h - 1) as f64);
        let x0 = fx.floor() as usize;
        let y0 = fy.floor() as usize;
        let x1 = (x0 + 1).min(self.w - 1);
        let y1 = (y0 + 1).min(self.h - 1);
        let ax = fx - x0 as f64;
        let ay = fy - y0 as f64;
        let top = self.at(x0, y0) as f64 * (1.0 - ax) + self.at(x1, y0) as f64 * ax;
        let bottom = self.at(x0, y1) as f64 * (1.0 - ax) + self.at(x1, y1) as f64 * ax;
        top * (1.0 - ay) + bottom * ay
    }

    /// Half the size: each pixel the mean of a 2x2 block (pixel `(x, y)` here is centred
    /// on `(2x + 0.5, 2y + 0.5)` of `self`).
    pub fn half(&self) -> Plane {
        let w = self.w / 2;
        let h = self.h / 2;
        let mut data = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let s = self.at(2 * x, 2 * y)
                    + self.at(2 * x + 1, 2 * y)
                    + self.at(2 * x, 2 * y + 1)
                    + self.at(2 * x + 1, 2 * y + 1);
                data.push(s * 0.25);
            }
        }
        Plane { w, h, data }
    }

    /// Gaussian smoothing (separable, the border replicated).
    pub fn gaussian(&self, sigma: f32) -> Plane {
        let radius = (3.0 * sigma).ceil().max(1.0) as usize;
        let mut kernel: Vec<f32> = (0..=2 * radius)
            .map(|i| {
                let d = i as f32 - radius as f32;
                (-d * d / (2.0 * sigma * sigma)).exp()
            })
            .collect();
        let total: f32 = kernel.iter().sum();
        kernel.iter_mut().for_each(|k| *k /= total);
        let (w, h) = (self.w, self.h);
        let r = radius;
        // Rows: each padded with its end pixels replicated, then convolved.
        let mut tmp = vec![0.0f32; w * h];
        let mut padded = vec![0.0f32; w + 2 * r];
        for y in 0..h {
            let row = &self.data[y * w..(y + 1) * w];
            let (first, last) = (row[0], row[w - 1]);
            padded[..r].fill(first);
            padded[r..r + w].copy_from_slice(row);
            padded[r + w..].fill(last);
            let dst = &mut tmp[y * w..(y + 1) * w];
            for (k, &kv) in kernel.iter().enumerate() {
                for (d, s) in dst.iter_mut().zip(&padded[k..k + w]) {
                    *d += kv * s;
                }
            }
        }
        // Columns: whole rows at a time, the first and last rows replicated.
        let mut out = vec![0.0f32; w * h];
        for y in 0..h {
            let dst = &mut out[y * w..(y + 1) * w];
            for (k, &kv) in kernel.iter().enumerate() {
                let yy = (y + k).saturating_sub(r).min(h - 1);
                let src = &tmp[yy * w..(yy + 1) * w];
                for (d, s) in dst.iter_mut().zip(src) {
                    *d += kv * s;
                }
            }
        }
        Plane { w, h, data: out }
    }
}

/// True if `image`'s width, height and stride fit its buffer.
pub(crate) fn gray_is_valid(image: &GrayImage<'_>) -> bool {
    image.width > 0
        && image.height > 0
        && image.stride >= image.width
        && (image.height - 1)
            .checked_mul(image.stride)
            .and_then(|n| n.checked_add(image.width))
            .is_some_and(|n| n <= image.data.len())
}

/// Bilinear interpolation in a (valid) 8-bit image, the border replicated.
pub(crate) fn sample_gray(image: &GrayImage<'_>, x: f64, y: f64) -> f64 {
    let fx = if x.is_finite() { x } else { 0.0 };
    let fy = if y.is_finite() { y } else { 0.0 };
    let fx = fx.clamp(0.0, (image.width - 1) as f64);
    let fy = fy.clamp(0.0, (image.height - 1) as f64);
    let x0 = fx.floor() as usize;
    let y0 = fy.floor() as usize;
    let x1 = (x0 + 1).min(image.width - 1);
    let y1 = (y0 + 1).min(image.height - 1);
    let ax = fx - x0 as f64;
    let ay = fy - y0 as f64;
    let at = |x: usize, y: usize| image.data[y * image.stride + x] as f64;
    let top = at(x0, y0) * (1.0 - ax) + at(x1, y0) * ax;
    let bottom = at(x0, y1) * (1.0 - ax) + at(x1, y1) * ax;
    top * (1.0 - ay) + bottom * ay
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_images_are_refused() {
        let data = [0u8; 10];
        let bad = GrayImage {
            width: 4,
            height: 4,
            stride: 4,
            data: &data,
        };
        assert!(Plane::from_gray(&bad).is_none());
        let good = GrayImage::new(5, 2, &data).unwrap();
        assert!(Plane::from_gray(&good).is_some());
    }

    #[test]
    fn sampling_interpolates_and_clamps() {
        let data = [0u8, 100, 200, 50];
        let img = GrayImage::new(2, 2, &data).unwrap();
        let p = Plane::from_gray(&img).unwrap();
        assert!((p.sample(0.5, 0.0) - 50.0).abs() < 1e-9);
        assert!((p.sample(-3.0, 5.0) - 200.0).abs() < 1e-9);
        assert!((sample_gray(&img, 0.5, 0.5) - 87.5).abs() < 1e-9);
        assert!((p.gaussian(1.0).data.iter().sum::<f32>() / 4.0 - 87.5).abs() < 60.0);
        assert_eq!(p.half().data, vec![87.5]);
    }
}
