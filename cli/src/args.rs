//! Checks on numeric arguments, so that a value no camera can use is refused by name before any
//! work starts (an image 0 pixels wide panicked in the splatter; a field of view of 0°, 360° or
//! NaN wrote a black picture and exited 0).

/// The largest image side: the texture limit the device is asked for (`gpu::required_limits`).
const MAX_SIDE: u32 = 8192;

pub fn image_side(s: &str) -> Result<u32, String> {
    let side: u32 = s.parse().map_err(|e| format!("{e}"))?;
    if (1..=MAX_SIDE).contains(&side) {
        Ok(side)
    } else {
        Err(format!("{side} pixels: an image side is 1 to {MAX_SIDE}"))
    }
}

/// A vertical field of view in degrees: above 0 and below 180.
pub fn field_of_view(s: &str) -> Result<f32, String> {
    let fov = finite(s)?;
    if fov > 0.0 && fov < 180.0 {
        Ok(fov)
    } else {
        Err(format!(
            "{fov}°: a field of view is above 0° and below 180°"
        ))
    }
}

/// An angle in degrees (any finite value).
pub fn angle(s: &str) -> Result<f32, String> {
    finite(s)
}

/// A time in seconds (any finite value; motions clamp or loop it).
pub fn seconds(s: &str) -> Result<f64, String> {
    let t: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if t.is_finite() {
        Ok(t)
    } else {
        Err(format!("{t}: not a finite number"))
    }
}

/// Frames per second of a written sequence: above 0, at most 240.
pub fn frame_rate(s: &str) -> Result<f32, String> {
    let fps = finite(s)?;
    if fps > 0.0 && fps <= 240.0 {
        Ok(fps)
    } else {
        Err(format!(
            "{fps} fps: a frame rate is above 0 and at most 240"
        ))
    }
}

/// Frames of a sequence: 1 to 100,000.
pub fn frame_count(s: &str) -> Result<usize, String> {
    let n: usize = s.parse().map_err(|e| format!("{e}"))?;
    if (1..=100_000).contains(&n) {
        Ok(n)
    } else {
        Err(format!("{n} frames: a sequence has 1 to 100000"))
    }
}

fn finite(s: &str) -> Result<f32, String> {
    let v: f32 = s.parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{v}: not a finite number"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_no_camera_can_use_are_refused() {
        for bad in ["0", "8193", "-1", "x"] {
            assert!(image_side(bad).is_err(), "{bad}");
        }
        assert_eq!(image_side("8192"), Ok(8192));
        for bad in ["0", "180", "360", "-10", "NaN", "inf"] {
            assert!(field_of_view(bad).is_err(), "{bad}");
        }
        assert_eq!(field_of_view("0.5"), Ok(0.5));
        for bad in ["NaN", "inf", "-inf"] {
            assert!(angle(bad).is_err() && seconds(bad).is_err(), "{bad}");
        }
        assert_eq!(angle("-720"), Ok(-720.0));
    }
}
