//! The calibration target: a chessboard, described by its inner corners.

use crate::error::{CalibError, CalibResult};
use nalgebra::Vector3;

/// A chessboard target: `cols` x `rows` inner corners (where four squares meet), squares
/// `square_mm` wide. `9x6` is OpenCV's sample board (10 x 7 squares).
///
/// Corners are numbered row by row, as OpenCV numbers them: corner `r * cols + c` is in
/// row `r`, column `c`, at `(c * square_mm, r * square_mm, 0)` on the board.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Board {
    /// Inner corners along a row.
    pub cols: usize,
    /// Inner corners along a column.
    pub rows: usize,
    /// Side of one square, millimetres.
    pub square_mm: f64,
}

impl Board {
    /// A board, checked: at least 3 x 3 inner corners, a positive finite square.
    pub fn new(cols: usize, rows: usize, square_mm: f64) -> CalibResult<Board> {
        if cols < 3 || rows < 3 {
            return Err(CalibError::InvalidBoard(format!(
                "{cols}x{rows} inner corners: need at least 3x3"
            )));
        }
        if cols > 64 || rows > 64 {
            return Err(CalibError::InvalidBoard(format!(
                "{cols}x{rows} inner corners: at most 64 along a side"
            )));
        }
        if !(square_mm.is_finite() && square_mm > 0.0) {
            return Err(CalibError::InvalidBoard(format!(
                "square size {square_mm} mm is not a positive number"
            )));
        }
        Ok(Board {
            cols,
            rows,
            square_mm,
        })
    }

    /// Number of inner corners.
    pub fn len(&self) -> usize {
        self.cols * self.rows
    }

    /// Always false: a checked board has at least 9 corners.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The corners on the board, millimetres, in corner order (z = 0).
    pub fn object_points(&self) -> Vec<Vector3<f64>> {
        (0..self.rows)
            .flat_map(|r| {
                (0..self.cols).map(move |c| {
                    Vector3::new(c as f64 * self.square_mm, r as f64 * self.square_mm, 0.0)
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_are_numbered_row_by_row() {
        let b = Board::new(9, 6, 25.0).unwrap();
        let p = b.object_points();
        assert_eq!(p.len(), 54);
        assert_eq!(p[1], Vector3::new(25.0, 0.0, 0.0));
        assert_eq!(p[9], Vector3::new(0.0, 25.0, 0.0));
        assert_eq!(p[53], Vector3::new(200.0, 125.0, 0.0));
    }

    #[test]
    fn bad_boards_are_refused() {
        assert!(Board::new(2, 6, 25.0).is_err());
        assert!(Board::new(9, 6, 0.0).is_err());
        assert!(Board::new(9, 6, f64::NAN).is_err());
    }
}
