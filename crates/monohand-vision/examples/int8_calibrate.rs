//! Writes the int8 calibration tables that monohand ships (`crates/monohand-vision/int8/`),
//! from the calibration frames of ../shared (see `monohand_vision::int8`): the shared photos
//! and every 5th frame of the dev video's first half, read by the f32 pipeline.
//!
//! ```sh
//! cargo run --release -p monohand-vision --example int8_calibrate -- ../shared/data crates/monohand-vision/int8
//! ```
//!
//! `tests/int8_calibration.rs` makes the tables again and checks they are the shipped ones.

use std::path::PathBuf;

use monohand_vision::int8::{calibrate, calibration_images, FRAMES};
use monohand_vision::{ModelOptions, ModelVariant};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args_os().skip(1);
    let (Some(data), Some(out)) = (args.next(), args.next()) else {
        return Err("usage: int8_calibrate SHARED_DATA_DIR OUTPUT_DIR".into());
    };
    let (data, out) = (PathBuf::from(data), PathBuf::from(out));
    let images = calibration_images(&data)?;
    for variant in [ModelVariant::Full, ModelVariant::Lite] {
        let models = ModelOptions {
            palm: variant,
            landmark: variant,
            ..Default::default()
        };
        for (file, table) in calibrate(&models, &images, FRAMES)? {
            let path = out.join(file.file_name().replace(".tflite", ".txt"));
            std::fs::write(&path, table.to_text())?;
            println!("{}: {} layers", path.display(), table.ranges.len());
        }
    }
    Ok(())
}
