//! The project's colours, shared by the overlays drawn on frames and the glTF export, so
//! that a finger has one colour everywhere.

use monohand_core::hand_model::HandSide;

/// An 8-bit RGB colour.
pub type Rgb = [u8; 3];

/// Colours of the five fingers (thumb, index, middle, ring, little).
pub const FINGER_COLORS: [Rgb; 5] = [
    [255, 70, 70],
    [255, 210, 0],
    [60, 220, 60],
    [0, 170, 255],
    [210, 90, 255],
];

/// The colour that marks a hand's side: cyan for left, orange for right.
pub fn side_color(side: HandSide) -> Rgb {
    match side {
        HandSide::Left => [0, 230, 255],
        HandSide::Right => [255, 140, 0],
    }
}
