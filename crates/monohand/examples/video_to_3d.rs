//! A video file to absolute 3D hand joints, one line per hand per frame:
//! `cargo run --release -p monohand --example video_to_3d -- clip.mp4 [camera.json]`
use monohand::prelude::*;
use monohand_media::video::{VideoInput, VideoReader};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let video = args
        .next()
        .ok_or(anyhow::anyhow!("usage: video_to_3d VIDEO [CAMERA]"))?;
    let cameras = match args.next() {
        Some(path) => vec![monohand_io::calibration::read_camera(
            std::path::Path::new(&path),
        )?],
        None => Vec::new(), // a generic camera for the video's size
    };
    let mut session = Session::new(cameras, SessionOptions::default())?;
    for frame in VideoReader::open(&VideoInput::parse(&video))? {
        let frame = frame?;
        for done in session.process(&[&frame.image], frame.timestamp_s)? {
            for hand in &done.hands {
                if let Some(fit) = &hand.fit {
                    let wrist = fit.joints_3d[0];
                    println!(
                        "frame {} hand {} {:?}: wrist {:.0} {:.0} {:.0} mm",
                        done.vision.index, hand.id, hand.side, wrist.x, wrist.y, wrist.z
                    );
                }
            }
        }
    }
    Ok(())
}
