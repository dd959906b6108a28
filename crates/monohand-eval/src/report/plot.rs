//! PNG line charts with plotters, without system fonts.
//!
//! plotters draws text through a font library (font-kit needs fontconfig,
//! ab_glyph needs a font file). Instead, [`FontBackend`] wraps the bitmap
//! backend and draws text itself with the public-domain 8x8 bitmap font of
//! the `font8x8` crate (ASCII, scaled by whole pixels), so a report renders
//! the same everywhere and nothing is embedded beyond 1 KiB of glyphs. The
//! RGB buffer is encoded with the `png` crate.

use crate::error::{EvalError, EvalResult};
use plotters::prelude::*;
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind,
};
use std::path::Path;

/// Line colours, in run order.
pub const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// A bitmap backend that draws text with an 8x8 bitmap font.
pub struct FontBackend<'a> {
    inner: BitMapBackend<'a>,
}

impl<'a> FontBackend<'a> {
    /// Draws into an RGB buffer of `size` (3 bytes per pixel).
    pub fn with_buffer(buf: &'a mut [u8], size: (u32, u32)) -> Self {
        FontBackend {
            inner: BitMapBackend::with_buffer(buf, size),
        }
    }
}

/// Whole-pixel scale of the 8x8 glyphs for a font size in pixels.
fn glyph_scale(size: f64) -> i32 {
    ((size / 12.0).floor() as i32).max(1)
}

fn glyph(c: char) -> [u8; 8] {
    let i = c as usize;
    if i < 128 {
        font8x8::legacy::BASIC_LEGACY[i]
    } else {
        font8x8::legacy::BASIC_LEGACY[b'?' as usize]
    }
}

type Err<'a> = DrawingErrorKind<<BitMapBackend<'a> as DrawingBackend>::ErrorType>;

impl<'a> DrawingBackend for FontBackend<'a> {
    type ErrorType = <BitMapBackend<'a> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), Err<'a>> {
        self.inner.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), Err<'a>> {
        self.inner.present()
    }

    fn draw_pixel(&mut self, point: BackendCoord, color: BackendColor) -> Result<(), Err<'a>> {
        self.inner.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), Err<'a>> {
        self.inner.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), Err<'a>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn estimate_text_size<T: BackendTextStyle>(
        &self,
        text: &str,
        style: &T,
    ) -> Result<(u32, u32), Err<'a>> {
        let s = glyph_scale(style.size()) as u32;
        Ok((8 * s * text.chars().count() as u32, 8 * s))
    }

    fn draw_text<T: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &T,
        pos: BackendCoord,
    ) -> Result<(), Err<'a>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let s = glyph_scale(style.size());
        let width = 8 * s * text.chars().count() as i32;
        let height = 8 * s;
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let trans = style.transform();
        let (w, h) = self.get_size();
        for (k, c) in text.chars().enumerate() {
            let g = glyph(c);
            for (row, bits) in g.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) == 0 {
                        continue;
                    }
                    for sy in 0..s {
                        for sx in 0..s {
                            let lx = (k as i32 * 8 + col) * s + sx + dx;
                            let ly = row as i32 * s + sy + dy;
                            let (x, y) = trans.transform(lx, ly);
                            let (x, y) = (pos.0 + x, pos.1 + y);
                            if x >= 0 && x < w as i32 && y >= 0 && y < h as i32 {
                                self.inner.draw_pixel((x, y), color)?;
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// One line of a chart.
#[derive(Debug, Clone)]
pub struct Line {
    /// Legend text.
    pub label: String,
    /// The points.
    pub points: Vec<(f64, f64)>,
    /// Colour index into [`COLOURS`].
    pub colour: usize,
    /// Stroke width in pixels.
    pub width: u32,
}

/// A line chart's axes.
#[derive(Debug, Clone)]
pub struct Chart {
    /// Title above the chart.
    pub title: String,
    /// X axis description.
    pub x_desc: String,
    /// Y axis description.
    pub y_desc: String,
    /// X range.
    pub x: (f64, f64),
    /// Y range.
    pub y: (f64, f64),
    /// The lines.
    pub lines: Vec<Line>,
}

fn plot_err(path: &Path, e: impl std::fmt::Display) -> EvalError {
    EvalError::Plot {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Draws charts in a grid of `cols` columns into one PNG of `panel` pixels per chart.
pub fn draw_charts(
    path: &Path,
    charts: &[Chart],
    cols: usize,
    panel: (u32, u32),
) -> EvalResult<()> {
    let cols = cols.max(1).min(charts.len().max(1));
    let rows = charts.len().div_ceil(cols).max(1);
    let size = (panel.0 * cols as u32, panel.1 * rows as u32);
    let mut buf = vec![255u8; (size.0 * size.1 * 3) as usize];
    {
        let root = FontBackend::with_buffer(&mut buf, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
        let areas = root.split_evenly((rows, cols));
        for (chart, area) in charts.iter().zip(areas.iter()) {
            draw_one(area, chart).map_err(|e| plot_err(path, e))?;
        }
        root.present().map_err(|e| plot_err(path, e))?;
    }
    write_png(path, &buf, size)
}

fn draw_one<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    c: &Chart,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let mut chart = ChartBuilder::on(area)
        .caption(&c.title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(56)
        .build_cartesian_2d(c.x.0..c.x.1, c.y.0..c.y.1)?;
    chart
        .configure_mesh()
        .x_desc(c.x_desc.as_str())
        .y_desc(c.y_desc.as_str())
        .label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 12))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    for l in &c.lines {
        let colour = COLOURS[l.colour % COLOURS.len()];
        let style = Color::stroke_width(&colour, l.width);
        chart
            .draw_series(LineSeries::new(l.points.iter().copied(), style))?
            // plotters sizes the legend box with its own font estimate (about
            // 5.5 px per character at size 12), narrower than the 8 px glyphs:
            // trailing spaces widen the box without drawing anything.
            .label(format!("{}{}", l.label, " ".repeat(l.label.len() / 2 + 1)))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
    }
    if c.lines.iter().any(|l| !l.label.is_empty()) {
        chart
            .configure_series_labels()
            .label_font(("sans-serif", 12))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::LowerRight)
            .draw()?;
    }
    Ok(())
}

/// Encodes an RGB buffer as a PNG file.
pub fn write_png(path: &Path, rgb: &[u8], size: (u32, u32)) -> EvalResult<()> {
    let file = std::fs::File::create(path).map_err(|e| EvalError::write(path, e))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), size.0, size.1);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().map_err(|e| plot_err(path, e))?;
    w.write_image_data(rgb).map_err(|e| plot_err(path, e))?;
    w.finish().map_err(|e| plot_err(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_a_chart_with_text() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("c.png");
        let chart = Chart {
            title: "PCK".into(),
            x_desc: "mm".into(),
            y_desc: "fraction".into(),
            x: (0.0, 50.0),
            y: (0.0, 1.0),
            lines: vec![Line {
                label: "mono".into(),
                points: (0..=50).map(|t| (t as f64, t as f64 / 50.0)).collect(),
                colour: 0,
                width: 2,
            }],
        };
        draw_charts(&p, &[chart.clone(), chart], 2, (320, 240)).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut r = dec.read_info().unwrap();
        let mut img = vec![0; r.output_buffer_size().unwrap()];
        let info = r.next_frame(&mut img).unwrap();
        assert_eq!((info.width, info.height), (640, 240));
        // Black text pixels exist in the caption band (the top 30 rows).
        let dark = img[..640 * 30 * 3]
            .chunks(3)
            .filter(|p| p.iter().all(|&c| c < 60))
            .count();
        assert!(dark > 20, "no caption text drawn ({dark} dark pixels)");
        // The line colour is present.
        let c = COLOURS[0];
        assert!(img.chunks(3).any(|p| p == [c.0, c.1, c.2]));
    }
}
