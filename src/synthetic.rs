//! Synthetic photos with known answers: the body, textured with a smooth pattern over its rest
//! surface, posed and drawn from a known camera, with its exact tracking. Reconstruction tests
//! and `guava synth-photo` use them; they are labelled synthetic wherever they appear.

use glam::Vec3;
use image::{Rgba, RgbaImage};

use crate::body::{BodyModel, BodyPose, PoseError, PosedBody, vertex_normals};
use crate::camera::{Camera, GUAVA_INVTANFOV};
use crate::photo::SOURCE_SIZE;
use crate::raster::{Fragments, rasterize};

/// A smooth colour pattern over the rest surface: bands with periods of 0.6–1 m, so a 512²
/// texture resolves it and an exact reconstruction can match it closely.
pub fn banded_texture(p: Vec3) -> [f32; 3] {
    [
        0.5 + 0.35 * (9.0 * p.y + 2.0 * p.x).sin(),
        0.5 + 0.35 * (7.0 * p.x + 5.0 * p.z + 1.0).sin(),
        0.5 + 0.35 * (6.0 * p.y - 4.0 * p.z).cos(),
    ]
}

/// The synthetic source camera: GUAVA's (invtanfov 24, 512²) framing the upper body from the
/// front, `yaw` radians around it (positive turns towards the body's left).
pub fn upper_body_camera(body: &BodyModel, yaw: f32) -> Camera {
    let neck = body
        .joint_index("neck01")
        .map_or(Vec3::new(0.0, 1.45, 0.0), |j| body.joints[j].rest);
    // Chest height, and a distance that fits ~0.9 m of height in the 2/24-radian field of view.
    let target = Vec3::new(0.0, neck.y - 0.25, 0.0);
    let distance = 0.9 * GUAVA_INVTANFOV / 2.0;
    let eye = target + distance * Vec3::new(yaw.sin(), 0.0, yaw.cos());
    Camera::guava(
        Camera::look_at(eye, target, Vec3::Y),
        SOURCE_SIZE,
        GUAVA_INVTANFOV,
    )
}

/// The body posed by `pose`, seen by `camera`, coloured by `colour` of each pixel's rest-surface
/// point; alpha 255 on the body, 0 elsewhere.
pub fn photo(
    body: &BodyModel,
    pose: &BodyPose,
    camera: &Camera,
    colour: impl Fn(Vec3) -> [f32; 3],
) -> Result<RgbaImage, PoseError> {
    let mut posed = PosedBody::default();
    body.pose(pose, &mut posed)?;
    let f = rasterize(&posed.vertices, &body.triangles, camera);
    let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    Ok(RgbaImage::from_fn(camera.width, camera.height, |x, y| {
        let i = f.index(x, y);
        if f.triangle[i] < 0 {
            return Rgba([0, 0, 0, 0]);
        }
        let tri = body.triangles[f.triangle[i] as usize];
        let b = f.bary[i];
        let rest: Vec3 = (0..3).map(|k| b[k] * body.vertices[tri[k] as usize]).sum();
        let [r, g, bl] = colour(rest);
        Rgba([q(r), q(g), q(bl), 255])
    }))
}

/// A plainly lit drawing of `body` with its surface at `vertices` (rest or posed), as
/// rasterized into `f`: skin, eyes and mouth cavity in flat colours under a light from
/// `light`'s direction, grey where no triangle is, box-filtered by `supersample` (the fragments'
/// side is that many times the result's); RGB in [0, 1], row-major. The keypoint models accept it
/// as a person: the face model places its points on the body's own face this way.
pub fn shaded(
    body: &BodyModel,
    vertices: &[Vec3],
    f: &Fragments,
    light: Vec3,
    supersample: usize,
) -> Vec<f32> {
    let (mut scratch, mut normals) = (Vec::new(), Vec::new());
    vertex_normals(
        vertices,
        &body.triangles,
        &body.weld,
        &mut scratch,
        &mut normals,
    );
    let albedo = |part: Option<&str>| match part {
        Some(p) if p.starts_with("eye_back") => Vec3::new(0.85, 0.83, 0.8),
        Some(p) if p.starts_with("eye_front") => Vec3::new(0.25, 0.17, 0.12),
        Some(p) if p.starts_with("eye_cavity") || p == "mouth_cavity" => Vec3::splat(0.08),
        Some("tongue") => Vec3::new(0.55, 0.25, 0.25),
        _ => Vec3::new(0.8, 0.6, 0.5),
    };
    let s = supersample;
    let (w, h) = (f.width as usize / s, f.height as usize / s);
    let mut out = vec![0.0; w * h * 3];
    for y in 0..h * s {
        for x in 0..w * s {
            let i = f.index(x as u32, y as u32);
            let colour = if f.triangle[i] < 0 {
                Vec3::splat(0.55)
            } else {
                let tri = body.triangles[f.triangle[i] as usize];
                let b = f.bary[i];
                let normal: Vec3 = (0..3).map(|k| b[k] * normals[tri[k] as usize]).sum();
                let corner = tri[b
                    .iter()
                    .enumerate()
                    .fold(0, |m, (k, &v)| if v > b[m] { k } else { m })];
                albedo(body.part_of(corner as usize))
                    * (0.3 + 0.7 * normal.normalize_or_zero().dot(light).max(0.0))
            };
            let o = ((y / s) * w + x / s) * 3;
            for c in 0..3 {
                out[o + c] += colour[c] / (s * s) as f32;
            }
        }
    }
    out
}

/// The demo portrait pasted at `at` on a `size` canvas of its background's grey: a photo where
/// the centred square cuts the person, or leaves them small.
pub fn portrait_placed(size: [u32; 2], at: [i64; 2]) -> image::ImageResult<image::RgbImage> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/demo_portrait.png");
    let portrait = image::open(path)?.to_rgb8();
    let mut photo = image::RgbImage::from_pixel(size[0], size[1], image::Rgb([150, 150, 160]));
    image::imageops::replace(&mut photo, &portrait, at[0], at[1]);
    Ok(photo)
}
