//! A printable chessboard: the page's layout, as SVG, PDF or grey pixels.
//!
//! The board has `cols + 1` by `rows + 1` squares (so `cols x rows` inner corners), the
//! top-left square dark, with white paper around it at least [`BORDER_MM`] or 0.4 of a
//! square wide, whichever is more (the corner finder needs the light border to see the
//! board's outline). The page is A4 when the board, its border and the caption fit on
//! it (turned to landscape if that fits better), A3 when that fits, or else the board's
//! own size plus the border. A caption under the
//! board states the board and the square size it was drawn at, and asks the user to
//! measure a printed square: printers and PDF viewers scale pages ("fit to page"), and
//! the square's true size is the calibration's scale.

use crate::board::Board;

/// The least white paper around the squares, millimetres (more for large squares).
pub const BORDER_MM: f64 = 8.0;
/// Room under the board for the caption, millimetres.
const CAPTION_MM: f64 = 12.0;
/// ISO 216 A4 and A3, portrait, millimetres.
const PAGES_MM: [(f64, f64); 2] = [(210.0, 297.0), (297.0, 420.0)];

/// Where everything goes on the page, millimetres from the page's top-left corner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardPage {
    /// The board drawn.
    pub board: Board,
    /// Page width, mm.
    pub page_width_mm: f64,
    /// Page height, mm.
    pub page_height_mm: f64,
    /// Left edge of the first square, mm.
    pub left_mm: f64,
    /// Top edge of the first square, mm.
    pub top_mm: f64,
}

impl BoardPage {
    /// Lays out `board` on the smallest page that holds it (see the module docs).
    pub fn new(board: &Board) -> BoardPage {
        let s = board.square_mm;
        let border = BORDER_MM.max(0.4 * s);
        // The squares with their white border, and the caption under them.
        let w = (board.cols as f64 + 1.0) * s + 2.0 * border;
        let h = (board.rows as f64 + 1.0) * s + 2.0 * border + CAPTION_MM;
        let need = |pw: f64, ph: f64| w <= pw && h <= ph;
        let (pw, ph) = PAGES_MM
            .iter()
            .flat_map(|&(a, b)| [(a, b), (b, a)])
            .find(|&(pw, ph)| need(pw, ph))
            .unwrap_or((w, h));
        BoardPage {
            board: *board,
            page_width_mm: pw,
            page_height_mm: ph,
            left_mm: (pw - (board.cols as f64 + 1.0) * s) / 2.0,
            top_mm: (ph - CAPTION_MM - (board.rows as f64 + 1.0) * s) / 2.0,
        }
    }

    /// The dark squares as `(x, y, side)` in mm from the page's top-left corner.
    pub fn dark_squares(&self) -> Vec<(f64, f64, f64)> {
        let s = self.board.square_mm;
        (0..=self.board.rows)
            .flat_map(|r| (0..=self.board.cols).map(move |c| (r, c)))
            .filter(|(r, c)| (r + c) % 2 == 0)
            .map(|(r, c)| (self.left_mm + c as f64 * s, self.top_mm + r as f64 * s, s))
            .collect()
    }

    /// The caption printed under the board.
    pub fn caption(&self) -> String {
        format!(
            "monohand calibration board: {}x{} inner corners, {} mm squares. Print at 100% \
             (no \"fit to page\"), measure a printed square and pass that size with --square-mm.",
            self.board.cols,
            self.board.rows,
            fmt_mm(self.board.square_mm)
        )
    }

    /// Baseline of the caption, mm from the page's top.
    fn caption_y_mm(&self) -> f64 {
        self.top_mm + (self.board.rows as f64 + 1.0) * self.board.square_mm + CAPTION_MM * 0.6
    }

    /// The page as an SVG document, in millimetres.
    pub fn to_svg(&self) -> String {
        let (pw, ph) = (self.page_width_mm, self.page_height_mm);
        let mut out = format!(
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
             <svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}mm\" height=\"{}mm\" viewBox=\"0 0 {} {}\">\n\
             <rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"#ffffff\"/>\n<g fill=\"#000000\" shape-rendering=\"crispEdges\">\n",
            fmt_mm(pw), fmt_mm(ph), fmt_mm(pw), fmt_mm(ph), fmt_mm(pw), fmt_mm(ph)
        );
        for (x, y, s) in self.dark_squares() {
            out.push_str(&format!(
                "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/>\n",
                fmt_mm(x),
                fmt_mm(y),
                fmt_mm(s),
                fmt_mm(s)
            ));
        }
        out.push_str(&format!(
            "</g>\n<text x=\"{}\" y=\"{}\" font-family=\"Helvetica, Arial, sans-serif\" font-size=\"3\" fill=\"#000000\">{}</text>\n</svg>\n",
            fmt_mm(self.left_mm),
            fmt_mm(self.caption_y_mm()),
            self.caption().replace('"', "&quot;")
        ));
        out
    }

    /// The page as a one-page PDF (1.4, vector squares, the caption in Helvetica).
    pub fn to_pdf(&self) -> Vec<u8> {
        const PT: f64 = 72.0 / 25.4;
        let ph = self.page_height_mm * PT;
        let mut content = String::from("0 g\n");
        for (x, y, s) in self.dark_squares() {
            // PDF's origin is the page's bottom-left corner.
            content.push_str(&format!(
                "{:.4} {:.4} {:.4} {:.4} re f\n",
                x * PT,
                ph - (y + s) * PT,
                s * PT,
                s * PT
            ));
        }
        let caption = self
            .caption()
            .replace('\\', "\\\\")
            .replace('(', "\\(")
            .replace(')', "\\)");
        content.push_str(&format!(
            "BT /F1 8 Tf {:.4} {:.4} Td ({caption}) Tj ET\n",
            self.left_mm * PT,
            ph - self.caption_y_mm() * PT
        ));
        let objects = [
            "<< /Type /Catalog /Pages 2 0 R >>".to_string(),
            "<< /Type /Pages /Kids [3 0 R] /Count 1 >>".to_string(),
            format!(
                "<< /Type /Page /Parent 2 0 R /MediaBox [0 0 {:.4} {:.4}] /Contents 4 0 R \
                 /Resources << /Font << /F1 5 0 R >> >> >>",
                self.page_width_mm * PT,
                ph
            ),
            format!(
                "<< /Length {} >>\nstream\n{content}endstream",
                content.len()
            ),
            "<< /Type /Font /Subtype /Type1 /BaseFont /Helvetica >>".to_string(),
        ];
        let mut pdf = b"%PDF-1.4\n%\xe2\xe3\xcf\xd3\n".to_vec();
        let mut offsets = Vec::with_capacity(objects.len());
        for (i, body) in objects.iter().enumerate() {
            offsets.push(pdf.len());
            pdf.extend_from_slice(format!("{} 0 obj\n{body}\nendobj\n", i + 1).as_bytes());
        }
        let xref = pdf.len();
        let mut table = format!("xref\n0 {}\n0000000000 65535 f \n", objects.len() + 1);
        for o in offsets {
            table.push_str(&format!("{o:010} 00000 n \n"));
        }
        table.push_str(&format!(
            "trailer\n<< /Size {} /Root 1 0 R >>\nstartxref\n{xref}\n%%EOF\n",
            objects.len() + 1
        ));
        pdf.extend_from_slice(table.as_bytes());
        pdf
    }

    /// The page as grey pixels (0 dark, 255 white), `px_per_mm` pixels a millimetre (300 dpi
    /// is 300 / 25.4), row by row; returns `(width, height, pixels)`. No caption (a raster
    /// has no font here): the caller says the square size instead.
    pub fn rasterize(&self, px_per_mm: f64) -> (usize, usize, Vec<u8>) {
        let w = (self.page_width_mm * px_per_mm).round().max(1.0) as usize;
        let h = (self.page_height_mm * px_per_mm).round().max(1.0) as usize;
        let mut px = vec![255u8; w * h];
        for (x, y, s) in self.dark_squares() {
            let x0 = (x * px_per_mm).round() as usize;
            let y0 = (y * px_per_mm).round() as usize;
            let x1 = (((x + s) * px_per_mm).round() as usize).min(w);
            let y1 = (((y + s) * px_per_mm).round() as usize).min(h);
            for row in px[y0.min(h) * w..y1 * w].chunks_exact_mut(w) {
                row[x0.min(x1)..x1].fill(0);
            }
        }
        (w, h, px)
    }
}

/// A length in mm without trailing zeros (`25`, `22.5`).
fn fmt_mm(v: f64) -> String {
    let s = format!("{v:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_9x6_board_of_25_mm_is_laid_out_on_a4_landscape() {
        let page = BoardPage::new(&Board::new(9, 6, 25.0).unwrap());
        assert_eq!((page.page_width_mm, page.page_height_mm), (297.0, 210.0));
        // 10 x 7 squares, half of them dark (35).
        let dark = page.dark_squares();
        assert_eq!(dark.len(), 35);
        // Centred horizontally; the border of one square fits inside the margins.
        assert!((page.left_mm * 2.0 + 250.0 - 297.0).abs() < 1e-9);
        assert!(page.left_mm >= 10.0);
        assert!(page.top_mm >= 10.0);
        assert!(page.top_mm + 175.0 + CAPTION_MM <= 210.0 - 10.0);
        assert_eq!(dark[0], (page.left_mm, page.top_mm, 25.0));
    }

    #[test]
    fn large_boards_get_a_larger_page() {
        let page = BoardPage::new(&Board::new(9, 6, 35.0).unwrap());
        assert_eq!((page.page_width_mm, page.page_height_mm), (420.0, 297.0));
        let huge = BoardPage::new(&Board::new(12, 9, 60.0).unwrap());
        assert!((huge.page_width_mm - (13.0 * 60.0 + 2.0 * 24.0)).abs() < 1e-9);
    }

    #[test]
    fn the_svg_states_the_page_in_mm_and_every_dark_square() {
        let page = BoardPage::new(&Board::new(9, 6, 22.5).unwrap());
        let svg = page.to_svg();
        assert!(svg.contains("width=\"297mm\" height=\"210mm\""));
        assert_eq!(svg.matches("width=\"22.5\" height=\"22.5\"").count(), 35);
        assert!(svg.contains("9x6 inner corners, 22.5 mm squares"));
    }

    #[test]
    fn the_pdf_has_a_valid_cross_reference_table() {
        let page = BoardPage::new(&Board::new(9, 6, 25.0).unwrap());
        let pdf = page.to_pdf();
        let text = String::from_utf8_lossy(&pdf);
        assert!(text.starts_with("%PDF-1.4"));
        assert_eq!(text.matches(" re f").count(), 35);
        // Every object's offset in the table points at "N 0 obj".
        let xref_at: usize = text
            .rsplit("startxref\n")
            .next()
            .unwrap()
            .lines()
            .next()
            .unwrap()
            .parse()
            .unwrap();
        let table = String::from_utf8_lossy(&pdf[xref_at..]).to_string();
        for (i, line) in table.lines().skip(3).take(5).enumerate() {
            // Offsets count bytes (the header's binary comment is 4 bytes, not text).
            let off: usize = line[..10].parse().unwrap();
            let obj = format!("{} 0 obj", i + 1);
            assert_eq!(&pdf[off..off + obj.len()], obj.as_bytes(), "{line}");
        }
    }

    #[test]
    fn the_raster_has_the_squares_at_their_size() {
        let page = BoardPage::new(&Board::new(9, 6, 25.0).unwrap());
        let (w, h, px) = page.rasterize(4.0);
        assert_eq!((w, h), (1188, 840));
        let dark = px.iter().filter(|&&p| p == 0).count();
        assert_eq!(dark, 35 * 100 * 100);
        // The first square's top-left pixel is dark, the one before it white.
        let (x0, y0) = ((page.left_mm * 4.0) as usize, (page.top_mm * 4.0) as usize);
        assert_eq!(px[y0 * w + x0], 0);
        assert_eq!(px[y0 * w + x0 - 1], 255);
    }
}
