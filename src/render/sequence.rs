//! Frame sequences, shared by `guava render --sequence` and the viewer's export: which times a
//! motion is sampled at, how frames are named, and the frames as one animated GIF.

use std::path::{Path, PathBuf};

/// Sample times of a motion `duration` seconds long at `fps`: 0, 1/fps, … up to its end.
pub fn frame_times(duration: f64, fps: f32) -> Vec<f64> {
    let n = (duration.max(0.0) * fps as f64 + 1e-9).floor() as usize + 1;
    (0..n).map(|i| i as f64 / fps as f64).collect()
}

/// Frame `i`'s file in `dir`: `frame_00000.png`, … (sorted by name, they are in order).
pub fn frame_path(dir: &Path, i: usize) -> PathBuf {
    dir.join(format!("frame_{i:05}.png"))
}

/// The PNG `frames` as one looping animated GIF at `fps` (256 colours per frame), written
/// atomically.
pub fn write_gif(frames: &[PathBuf], fps: f32, out: &Path) -> anyhow::Result<()> {
    use anyhow::Context;
    use image::codecs::gif::{GifEncoder, Repeat};
    // GIF delays are in hundredths of a second.
    let delay = image::Delay::from_numer_denom_ms(1000, fps.round().max(1.0) as u32);
    crate::atomic_file::write_atomic(out, |file| {
        let mut gif = GifEncoder::new_with_speed(file, 10);
        gif.set_repeat(Repeat::Infinite)
            .map_err(std::io::Error::other)?;
        for path in frames {
            let rgba = image::open(path)
                .map_err(|e| std::io::Error::other(format!("{}: {e}", path.display())))?
                .to_rgba8();
            gif.encode_frame(image::Frame::from_parts(rgba, 0, 0, delay))
                .map_err(std::io::Error::other)?;
        }
        Ok(())
    })
    .with_context(|| format!("writing {}", out.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_motion_is_sampled_from_its_start_to_its_end() {
        assert_eq!(frame_times(8.0, 2.0).len(), 17);
        assert_eq!(frame_times(8.0, 2.0)[16], 8.0);
        assert_eq!(frame_times(0.0, 30.0), [0.0]);
        // 241 frames at 30 fps last 8 s: resampled at 30 fps, 241 again.
        assert_eq!(frame_times(240.0 / 30.0, 30.0).len(), 241);
    }
}
