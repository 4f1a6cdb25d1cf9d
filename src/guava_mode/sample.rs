//! Projection sampling as the reference does it (`ubody_gaussian.py:sample_prj_feature`,
//! `convert_pixel_feature_to_uv`): a world point to GUAVA's NDC, `invtanfov · (x, y) / (z + 1e-7)`
//! with no near-plane test, then PyTorch's `grid_sample(bilinear, align_corners=False)` of planar
//! feature maps there.

use glam::{Mat4, Vec2, Vec3};

/// What `grid_sample` reads outside the map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Padding {
    /// The edge pixel (vertices: `padding_mode='border'`).
    Border,
    /// Zero (texels: `padding_mode='zeros'`).
    Zeros,
}

/// GUAVA's NDC of a world point: x right, y down, ±1 at the image edges.
pub fn project_ndc(view_from_world: &Mat4, invtanfov: f32, world: Vec3) -> Vec2 {
    let p = view_from_world.transform_point3(world);
    Vec2::new(p.x, p.y) * invtanfov / (p.z + 1e-7)
}

/// Bilinear sample of `maps` (`channels` planes of `side`², row 0 at the top) at `ndc`, into
/// `out[..channels]`. A non-finite point samples nothing (zeros).
pub fn grid_sample(
    maps: &[f32],
    channels: usize,
    side: usize,
    ndc: Vec2,
    padding: Padding,
    out: &mut [f32],
) {
    debug_assert_eq!(maps.len(), channels * side * side);
    out[..channels].fill(0.0);
    if !ndc.is_finite() {
        return;
    }
    // align_corners=False: ndc −1 is the left edge of pixel 0; pixel i's centre is at
    // (2i + 1)/side − 1.
    let unnormalise = |v: f32| {
        let p = ((v + 1.0) * side as f32 - 1.0) / 2.0;
        match padding {
            Padding::Border => p.clamp(0.0, (side - 1) as f32),
            Padding::Zeros => p,
        }
    };
    let (x, y) = (unnormalise(ndc.x), unnormalise(ndc.y));
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let plane = side * side;
    for (dx, dy, w) in [
        (0, 0, (1.0 - fx) * (1.0 - fy)),
        (1, 0, fx * (1.0 - fy)),
        (0, 1, (1.0 - fx) * fy),
        (1, 1, fx * fy),
    ] {
        let (px, py) = (x0 as i64 + dx, y0 as i64 + dy);
        if w == 0.0 || px < 0 || py < 0 || px >= side as i64 || py >= side as i64 {
            continue;
        }
        let at = py as usize * side + px as usize;
        for (c, o) in out[..channels].iter_mut().enumerate() {
            *o += w * maps[c * plane + at];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4×4 map whose value is 10·row + column, two channels (the second negated).
    fn ramp() -> Vec<f32> {
        let one: Vec<f32> = (0..16).map(|i| (10 * (i / 4) + i % 4) as f32).collect();
        one.iter().copied().chain(one.iter().map(|v| -v)).collect()
    }

    #[test]
    fn pixel_centres_edges_and_padding_follow_align_corners_false() {
        let maps = ramp();
        let mut out = [0.0; 2];
        let mut at = |x: f32, y: f32, padding| {
            grid_sample(&maps, 2, 4, Vec2::new(x, y), padding, &mut out);
            out
        };
        // Pixel (1, 2)'s centre is at ndc ((2·1 + 1)/4 − 1, (2·2 + 1)/4 − 1).
        assert_eq!(at(-0.25, 0.25, Padding::Zeros), [21.0, -21.0]);
        // Halfway between pixels (1, 2) and (2, 2).
        assert_eq!(at(0.0, 0.25, Padding::Zeros), [21.5, -21.5]);
        // The left edge: half the edge pixel with zeros, all of it with border.
        assert_eq!(at(-1.0, 0.25, Padding::Zeros), [10.0, -10.0]);
        assert_eq!(at(-1.0, 0.25, Padding::Border), [20.0, -20.0]);
        // Far outside: nothing, or the corner pixel.
        assert_eq!(at(5.0, 5.0, Padding::Zeros), [0.0, 0.0]);
        assert_eq!(at(5.0, 5.0, Padding::Border), [33.0, -33.0]);
        assert_eq!(at(f32::NAN, 0.0, Padding::Border), [0.0, 0.0]);
    }

    #[test]
    fn projection_is_invtanfov_over_depth() {
        let w2c = Mat4::from_translation(Vec3::new(0.0, 0.0, 2.0));
        let ndc = project_ndc(&w2c, 24.0, Vec3::new(0.05, -0.1, 0.0));
        assert!(
            (ndc - Vec2::new(0.6, -1.2)).abs().max_element() < 1e-6,
            "{ndc}"
        );
    }
}
