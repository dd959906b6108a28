//! A borrowed 8-bit grey image.

use crate::error::{CalibError, CalibResult};

/// A caller-owned 8-bit grey image, row-major, `stride` bytes between rows.
#[derive(Debug, Clone, Copy)]
pub struct GrayImage<'a> {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Bytes from one row to the next (at least `width`).
    pub stride: usize,
    /// The pixels: `height` rows of `stride` bytes (the last row may be `width` long).
    pub data: &'a [u8],
}

impl<'a> GrayImage<'a> {
    /// A tightly packed image (`stride == width`), checked.
    pub fn new(width: usize, height: usize, data: &'a [u8]) -> CalibResult<GrayImage<'a>> {
        GrayImage::with_stride(width, height, width, data)
    }

    /// An image with rows `stride` bytes apart, checked.
    pub fn with_stride(
        width: usize,
        height: usize,
        stride: usize,
        data: &'a [u8],
    ) -> CalibResult<GrayImage<'a>> {
        if width == 0 || height == 0 {
            return Err(CalibError::InvalidImage(format!(
                "{width}x{height} has no pixels"
            )));
        }
        if stride < width {
            return Err(CalibError::InvalidImage(format!(
                "stride {stride} is less than the width {width}"
            )));
        }
        let needed = (height - 1) * stride + width;
        if data.len() < needed {
            return Err(CalibError::InvalidImage(format!(
                "{width}x{height} (stride {stride}) needs {needed} bytes, got {}",
                data.len()
            )));
        }
        Ok(GrayImage {
            width,
            height,
            stride,
            data,
        })
    }

    /// The pixel at column `x`, row `y` (no bounds check beyond the slice's).
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> u8 {
        self.data[y * self.stride + x]
    }
}
