//! Finding a chessboard's inner corners in a grey image, with subpixel refinement.
//!
//! Ordering: row by row (`cols` corners a row), as [`Board::object_points`] numbers
//! them, and right-handed in the image: from corner 0, the row direction (+c) turned
//! 90 degrees clockwise on the screen (y down) is the column direction (+r), so the
//! board's z axis points away from the camera. Where the board's colouring tells its
//! rotations apart (`cols + rows` odd, e.g. 9x6: its `(cols + 1) x (rows + 1)` squares
//! then look different turned half a turn), corner 0 is the one whose outer diagonal
//! square (the board's corner square touching it) is dark; otherwise the one nearest the
//! image's top-left corner (pixel (0, 0)). Square boards (`cols == rows`) are numbered
//! by the same rules among their four turns: the dark rule first where it tells them
//! apart (odd `cols`), then the top-left one. Both cameras of a rig thus number the same
//! physical corners alike, whichever way up the board is seen.
//!
//! Method (no OpenCV): the image is halved until its longer side is at most 1024 pixels,
//! smoothed (Gaussian, sigma 1 pixel), and every pixel's ChESS saddle response computed
//! (Bennett and Lasenby 2014: a ring of 16 samples 5 pixels out; X corners respond,
//! edges, blobs and the board's outer L corners do not). Local maxima are the candidates.
//! A 3x3 grid is seeded around a candidate (neighbours both ways along two directions
//! and the diagonals, the four squares between them alternating dark and light), then
//! grown a whole row or column at a time on each side: each new corner is predicted from
//! the last three of its line, taken from the candidates near the prediction (or the
//! strongest response there), and the new squares must continue the dark/light
//! alternation. The largest grid is the board if its size is the board's; the corners
//! are then refined at full resolution as `cv::cornerSubPix` does ([`refine_corners`]).
//! The squares are told apart by local contrast only, so uneven lighting, blur and
//! perspective tilt are tolerated; the board needs a light margin or background around
//! it (its outer squares' corners must not look like X corners), as OpenCV's does.

mod detect;
mod grid;
mod plane;
mod refine;

use crate::board::Board;
use crate::image::GrayImage;
use grid::Grid;
use nalgebra::Point2;
use plane::Plane;

/// A board found in an image.
#[derive(Debug, Clone, PartialEq)]
pub struct FoundBoard {
    /// The `board.len()` inner corners in board order, pixels, subpixel-refined.
    pub corners: Vec<Point2<f64>>,
    /// How sharp the board is, whatever the lighting: for each edge between adjacent
    /// corners, the steepest grey-level slope across it divided by the grey-level step
    /// between its two squares, the mean over the edges (1/pixel, full resolution); about
    /// `0.4 / sigma` for edges blurred by a Gaussian of `sigma` pixels, up to about 1 for
    /// perfectly sharp ones. Higher is sharper; used to choose frames from a video.
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
    /// A chessboard was seen with another number of inner corners: a grid that cannot be
    /// part of the board given (at least this size if the image's edge cuts it).
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

/// The detection level's longer side at most (larger images are halved until it fits).
const MAX_DETECTION_SIDE: usize = 1024;
/// The least ChESS response of a candidate (about 8 times the contrast of an ideal X).
const MIN_RESPONSE: f32 = 40.0;
/// Candidates kept at most (the strongest).
const MAX_CANDIDATES: usize = 1500;
/// The least grey-level difference between adjacent squares (smoothed detection level).
const MIN_CONTRAST: f64 = 8.0;

/// Finds `board`'s inner corners in `image`, refined to subpixel accuracy, numbered as
/// the module's documentation says.
///
/// Returns [`NotFound::Partial`] when a grid that fits in the board is seen but not all
/// of it (cut by the image's edge, covered, too blurred), [`NotFound::OtherSize`] when a
/// grid is seen that cannot be part of the board (e.g. 9x6 when 8x6 is asked; its
/// longer side first if `board`'s is; at least that size if the image's edge cuts it), and
/// [`NotFound::NoBoard`] otherwise (also for images or boards that are not valid).
pub fn find_chessboard(image: &GrayImage<'_>, board: &Board) -> Result<FoundBoard, NotFound> {
    find_chessboard_with(image, board, None)
}

/// [`find_chessboard`] with the subpixel refinement's half window given (OpenCV's
/// `cornerSubPix` `winSize`: 11 is its tutorials' 23x23 window) instead of fitted to the
/// squares ([`refine_half_window`]); `None` fits it.
pub fn find_chessboard_with(
    image: &GrayImage<'_>,
    board: &Board,
    half_window: Option<usize>,
) -> Result<FoundBoard, NotFound> {
    if board.cols < 2 || board.rows < 2 || board.cols > 1000 || board.rows > 1000 {
        return Err(NotFound::NoBoard);
    }
    let full = Plane::from_gray(image).ok_or(NotFound::NoBoard)?;
    let mut level = full;
    let mut scale = 1usize;
    while level.w.max(level.h) > MAX_DETECTION_SIDE {
        level = level.half();
        scale *= 2;
    }
    if level.w < 3 * detect::RING_RADIUS || level.h < 3 * detect::RING_RADIUS {
        return Err(NotFound::NoBoard);
    }
    let smooth = level.gaussian(1.0);
    drop(level);
    let response = detect::chess_response(&smooth);
    let strongest = response.data.iter().copied().fold(0.0f32, f32::max);
    let threshold = (0.02 * strongest).max(MIN_RESPONSE);
    let cands = detect::candidates(&response, threshold, 3, MAX_CANDIDATES);
    if cands.len() < 9 {
        return Err(NotFound::NoBoard);
    }
    let assembler = grid::Assembler {
        img: &smooth,
        response: &response,
        cands: &cands,
        min_contrast: MIN_CONTRAST,
        fill_threshold: 0.5 * threshold,
    };
    let found = assembler
        .assemble((board.cols, board.rows))
        .ok_or(NotFound::NoBoard)?;
    let g = &found.grid;
    let seen = g.pts.len();
    let same = (g.rows, g.cols) == (board.rows, board.cols)
        || (g.cols, g.rows) == (board.rows, board.cols);
    if !same {
        let fits = (g.rows <= board.rows && g.cols <= board.cols)
            || (g.cols <= board.rows && g.rows <= board.cols);
        return Err(if !fits {
            let (big, small) = (g.rows.max(g.cols), g.rows.min(g.cols));
            if board.cols >= board.rows {
                NotFound::OtherSize {
                    cols: big,
                    rows: small,
                }
            } else {
                NotFound::OtherSize {
                    cols: small,
                    rows: big,
                }
            }
        } else if found.cut || seen > 9 {
            NotFound::Partial {
                seen,
                expected: board.len(),
            }
        } else {
            NotFound::NoBoard
        });
    }
    let ordered = board_order(g, board, &smooth).ok_or(NotFound::NoBoard)?;
    // Detection-level pixel centres to full resolution: x_full = s * x + (s - 1) / 2.
    let offset = (scale as f64 - 1.0) / 2.0;
    let mut corners: Vec<Point2<f64>> = ordered
        .pts
        .iter()
        .map(|p| Point2::new(p.x * scale as f64 + offset, p.y * scale as f64 + offset))
        .collect();
    let spacing = min_spacing(&corners, board.rows, board.cols);
    let half_window = half_window.unwrap_or_else(|| refine_half_window(spacing));
    refine_corners(image, &mut corners, half_window);
    let sharpness = refine::sharpness(image, &corners, board.rows, board.cols);
    Ok(FoundBoard { corners, sharpness })
}

/// The half window [`find_chessboard`] refines with, for corners `spacing` pixels apart
/// at the least: 5 (OpenCV's usual 11x11 window, `winSize (5, 5)`) for squares of 15-60
/// pixels, a third of the spacing for smaller squares (the window must not reach the
/// next corners), a twelfth for larger ones (up to 15).
pub fn refine_half_window(spacing: f64) -> usize {
    if !spacing.is_finite() || spacing < 6.0 {
        return 2;
    }
    if spacing < 15.0 {
        return ((spacing / 3.0).floor() as usize).max(2);
    }
    ((spacing / 12.0).round() as usize).clamp(5, 15)
}

/// The least distance between adjacent corners of a `rows` x `cols` grid.
fn min_spacing(corners: &[Point2<f64>], rows: usize, cols: usize) -> f64 {
    let mut least = f64::INFINITY;
    for r in 0..rows {
        for c in 0..cols {
            let p = corners[r * cols + c];
            if c + 1 < cols {
                least = least.min((corners[r * cols + c + 1] - p).norm());
            }
            if r + 1 < rows {
                least = least.min((corners[(r + 1) * cols + c] - p).norm());
            }
        }
    }
    least
}

/// `grid` turned into `board`'s order (see the module's documentation), or `None` if
/// no turn of it has the board's size and is right-handed.
fn board_order(grid: &Grid, board: &Board, img: &Plane) -> Option<Grid> {
    let mut options: Vec<(Grid, bool)> = Vec::new();
    for transpose in [false, true] {
        for flip_rows in [false, true] {
            for flip_cols in [false, true] {
                let mut g = if transpose {
                    grid.transpose()
                } else {
                    grid.clone()
                };
                if flip_rows {
                    g = g.flip_rows();
                }
                if flip_cols {
                    g = g.flip_cols();
                }
                if g.rows != board.rows || g.cols != board.cols {
                    continue;
                }
                let a = g.at(0, 1) - g.at(0, 0);
                let b = g.at(1, 0) - g.at(0, 0);
                if a.x * b.y - a.y * b.x <= 0.0 {
                    continue;
                }
                let dark = first_square_dark(&g, img);
                options.push((g, dark));
            }
        }
    }
    if options.iter().any(|o| o.1) && options.iter().any(|o| !o.1) {
        options.retain(|o| o.1);
    }
    options
        .into_iter()
        .min_by(|a, b| a.0.at(0, 0).norm().total_cmp(&b.0.at(0, 0).norm()))
        .map(|o| o.0)
}

/// Whether the square between corners 0, 1, `cols` and `cols + 1` is dark: whether the
/// squares with an even `row + column` are darker than their neighbours, summed over
/// all pairs of adjacent squares.
fn first_square_dark(g: &Grid, img: &Plane) -> bool {
    let (cr, cc) = (g.rows - 1, g.cols - 1);
    let v: Vec<f64> = (0..cr * cc)
        .map(|k| g.cell_value(img, k / cc, k % cc))
        .collect();
    let mut even_minus_odd = 0.0;
    for r in 0..cr {
        for c in 0..cc {
            let sign = if (r + c) % 2 == 0 { 1.0 } else { -1.0 };
            if c + 1 < cc {
                even_minus_odd += sign * (v[r * cc + c] - v[r * cc + c + 1]);
            }
            if r + 1 < cr {
                even_minus_odd += sign * (v[r * cc + c] - v[(r + 1) * cc + c]);
            }
        }
    }
    even_minus_odd < 0.0
}

/// Refines corner positions to subpixel accuracy in place: each corner moves to the
/// point where the image gradients within `half_window` pixels around it are
/// orthogonal to the lines from it (the saddle point), as `cv::cornerSubPix` with a
/// `(2 half_window + 1)` square window, no dead zone, 30 iterations or a step under
/// 0.001 pixel. A corner that would move out of its window (or the image) is left where
/// it was; nothing is changed if `image` is not valid.
pub fn refine_corners(image: &GrayImage<'_>, corners: &mut [Point2<f64>], half_window: usize) {
    if !plane::gray_is_valid(image) {
        return;
    }
    for p in corners.iter_mut() {
        if p.x.is_finite() && p.y.is_finite() {
            *p = refine::refine_one(image, *p, half_window);
        }
    }
}
