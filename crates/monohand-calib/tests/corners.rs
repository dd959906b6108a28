//! The chessboard corner finder on OpenCV's 26 real stereo photos (9x6 board), on
//! synthetic variations of them, and on rendered boards.

use monohand_calib::corners::{find_chessboard, FoundBoard, NotFound};
use monohand_calib::{Board, GrayImage};
use nalgebra::{DMatrix, Matrix3, Point2, Vector3};
use std::path::PathBuf;
use std::time::Instant;

/// An owned grey image.
#[derive(Clone)]
struct Img {
    w: usize,
    h: usize,
    data: Vec<u8>,
}

impl Img {
    fn view(&self) -> GrayImage<'_> {
        GrayImage::new(self.w, self.h, &self.data).unwrap()
    }
}

fn photo_dir() -> PathBuf {
    let dir = monohand_testkit::shared_data().join("calibration/opencv_stereo_chessboard");
    assert!(
        dir.is_dir(),
        "{} not found (../shared beside the repository)",
        dir.display()
    );
    dir
}

/// The 26 photos' names, pairs in order: left01, right01, left02, ...
fn names() -> Vec<String> {
    (1..=14)
        .filter(|&i| i != 10)
        .flat_map(|i| [format!("left{i:02}.jpg"), format!("right{i:02}.jpg")])
        .collect()
}

fn load(name: &str) -> Img {
    let path = photo_dir().join(name);
    let img = image::open(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_luma8();
    Img {
        w: img.width() as usize,
        h: img.height() as usize,
        data: img.into_raw(),
    }
}

fn board() -> Board {
    Board::new(9, 6, 1.0).unwrap()
}

fn find(img: &Img) -> Result<FoundBoard, NotFound> {
    find_chessboard(&img.view(), &board())
}

/// OpenCV's corners (tests/data/opencv_stereo_chessboard_corners.txt), by photo.
fn reference() -> Vec<(String, Vec<Point2<f64>>)> {
    let text = include_str!("data/opencv_stereo_chessboard_corners.txt");
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let mut it = l.split_whitespace();
            let name = it.next().unwrap().to_string();
            let v: Vec<f64> = it.map(|s| s.parse().unwrap()).collect();
            assert_eq!(v.len(), 108, "{name}");
            (name, v.chunks(2).map(|c| Point2::new(c[0], c[1])).collect())
        })
        .collect()
}

/// For each of `ours`, the distance to the nearest of `theirs`; also checks the matching
/// is one to one.
fn match_distances(ours: &[Point2<f64>], theirs: &[Point2<f64>]) -> Vec<f64> {
    let mut taken = vec![false; theirs.len()];
    ours.iter()
        .map(|p| {
            let (k, d) = theirs
                .iter()
                .enumerate()
                .map(|(k, q)| (k, (p - q).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            assert!(!taken[k], "two corners match one of OpenCV's");
            taken[k] = true;
            d
        })
        .collect()
}

fn cross(a: nalgebra::Vector2<f64>, b: nalgebra::Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

#[test]
fn all_26_photos_agree_with_opencv() {
    let reference = reference();
    assert_eq!(reference.len(), 26);
    let mut all = Vec::new();
    let mut seconds = 0.0;
    for (name, theirs) in &reference {
        let img = load(name);
        let t = Instant::now();
        let found = find(&img);
        seconds += t.elapsed().as_secs_f64();
        let found = found.unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(found.corners.len(), 54, "{name}");
        let d = match_distances(&found.corners, theirs);
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        let max = d.iter().copied().fold(0.0, f64::max);
        eprintln!(
            "{name}: mean {mean:.3} px, max {max:.3} px from OpenCV's, sharpness {:.3}",
            found.sharpness
        );
        all.extend(d);
    }
    let mean = all.iter().sum::<f64>() / all.len() as f64;
    let max = all.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "26 photos: {} corners, mean {mean:.4} px, max {max:.4} px from OpenCV's; detection {:.1} ms a photo ({:.0} ms in all)",
        all.len(),
        seconds * 1000.0 / 26.0,
        seconds * 1000.0
    );
    assert!(mean < 0.1, "mean {mean}");
    assert!(max < 0.3, "max {max}");
}
