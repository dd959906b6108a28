//! Finding a chessboard's inner corners in a grey image, with subpixel refinement.
//!
//! Ordering: row by row (`cols` corners a row), as [`Board::object_points`] numbers
//! them, and right-handed in the image: from corner 0, the row direction (+c) turned
//! 90 degrees clockwise on the screen (y down) is the column direction (+r), so the
//! board's z axis points away from the camera. Where the board's colouring tells its
//! rotations apart (squares `cols + 1` by `rows + 1` with an odd total, e.g. 9x6), corner
//! 0 is the one whose outer diagonal square is dark; otherwise the one nearest the
//! image's top-left corner. Both cameras of a rig thus number the same physical corners
//! alike.

use crate::board::Board;
use crate::image::GrayImage;
use nalgebra::Point2;

/// A board found in an image.
#[derive(Debug, Clone, PartialEq)]
pub struct FoundBoard {
    /// The `board.len()` inner corners in board order, pixels, subpixel-refined.
    pub corners: Vec<Point2<f64>>,
    /// How sharp the board is: the mean gradient magnitude across its corners' edges
    /// (grey levels per pixel); higher is sharper. Used to choose frames from a video.
    pub sharpness: f64,
}

/// Why no board was returned for an image.
#[derive(Debug, Clone, PartialEq)]
pub enum NotFound {
    /// Nothing like a chessboard was seen.
    NoBoard,
    /// Part of a chessboard was seen but not all of its corners (cut by the image's
    /// edge, covered, or too blurred): `seen` corners of `expected`.
    Partial {
        /// Corners seen.
        seen: usize,
        /// Corners the board has.
        expected: usize,
    },
    /// A whole chessboard was seen, but with another number of inner corners.
    OtherSize {
        /// Inner corners along one side, as seen.
        cols: usize,
        /// Inner corners along the other side, as seen.
        rows: usize,
    },
}

impl std::fmt::Display for NotFound {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NotFound::NoBoard => write!(f, "no chessboard found"),
            NotFound::Partial { seen, expected } => write!(
                f,
                "only {seen} of the board's {expected} corners seen (partly out of frame, covered or blurred)"
            ),
            NotFound::OtherSize { cols, rows } => write!(
                f,
                "a chessboard with {cols}x{rows} inner corners, not the one given"
            ),
        }
    }
}

/// Finds `board`'s inner corners in `image`, refined to subpixel accuracy.
pub fn find_chessboard(image: &GrayImage<'_>, board: &Board) -> Result<FoundBoard, NotFound> {
    let _ = (image, board);
    Err(NotFound::NoBoard)
}

/// Refines corner positions to subpixel accuracy in place: each corner moves to the
/// point where the image gradients within `half_window` pixels around it are
/// orthogonal to the lines from it (the saddle point), as `cv::cornerSubPix`.
pub fn refine_corners(image: &GrayImage<'_>, corners: &mut [Point2<f64>], half_window: usize) {
    let _ = (image, corners, half_window);
}
