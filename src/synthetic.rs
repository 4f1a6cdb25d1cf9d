//! Synthetic photos with known answers: the body (bare, or in a jacket, with hair), textured
//! with smooth patterns over its rest surface, posed and drawn from a known camera, with its exact
//! tracking. Reconstruction tests, `guava synth-photo` and the fidelity benchmark use them; they
//! are labelled synthetic wherever they appear.

use glam::Vec3;
use image::{Rgba, RgbaImage};

use crate::body::{BodyModel, BodyPose, PoseError, PosedBody};
use crate::camera::{Camera, GUAVA_INVTANFOV};
use crate::photo::SOURCE_SIZE;
use crate::raster::{Fragments, rasterize};
use crate::tracking::SourceView;

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

/// A talking-head video's camera: GUAVA's (512²) looking at the body's neck from the front, `yaw`
/// radians around it, with 1.1 m of height in view (the head whole, the arms to the elbows at
/// rest, a forearm raised to wave).
pub fn portrait_camera(body: &BodyModel, yaw: f32) -> Camera {
    let neck = body
        .joint_index("neck01")
        .map_or(Vec3::new(0.0, 1.45, 0.0), |j| body.joints[j].rest);
    let target = Vec3::new(0.0, neck.y - 0.05, 0.0);
    let distance = 1.1 * GUAVA_INVTANFOV / 2.0;
    let eye = target + distance * Vec3::new(yaw.sin(), 0.0, yaw.cos());
    Camera::guava(
        Camera::look_at(eye, target, Vec3::Y),
        SOURCE_SIZE,
        GUAVA_INVTANFOV,
    )
}

/// The body posed by `pose`, seen by `camera` at its size, plainly lit ([`shaded`]: skin, eyes
/// and mouth in flat colours, lit from the body's front, on grey), drawn twice as fine and
/// box-filtered: a photo the keypoint models take for a person (faces included), for tests of
/// fitting and tracking whose answer is `pose`.
pub fn shaded_photo(
    body: &BodyModel,
    pose: &BodyPose,
    camera: &Camera,
) -> Result<RgbaImage, PoseError> {
    let mut posed = PosedBody::default();
    body.pose(pose, &mut posed)?;
    let side = camera.width;
    let fine = camera.scaled(2.0);
    let fragments = rasterize(&posed.vertices, &body.triangles, &fine);
    let rgb = shaded(body, &posed.vertices, &fragments, Vec3::Z, 2);
    Ok(RgbaImage::from_fn(side, camera.height, |x, y| {
        let i = 3 * (y * side + x) as usize;
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        Rgba([q(rgb[i]), q(rgb[i + 1]), q(rgb[i + 2]), 255])
    }))
}

/// A synthetic video with known answers: `count` frames at `fps` of the embedded demo motion
/// from `start` seconds, the body drawn by [`shaded_photo`] through [`portrait_camera`]; the
/// frames and each frame's true view (pose and camera).
pub fn demo_motion_clip(
    body: &BodyModel,
    start: f64,
    count: usize,
    fps: f32,
) -> Result<(Vec<crate::video::VideoFrame>, Vec<SourceView>), PoseError> {
    let demo = crate::tracking::demo_motion().expect("the embedded demo motion is valid");
    let retarget = crate::tracking::Retarget::new(&demo, body);
    let camera = portrait_camera(body, 0.0);
    (0..count)
        .map(|i| {
            let time_s = i as f64 / f64::from(fps);
            let mut pose = BodyPose::rest(body);
            retarget.sample(&demo, start + time_s, &mut pose);
            let pixels = shaded_photo(body, &pose, &camera)?;
            let view = SourceView {
                pose,
                camera,
                crop: None,
            };
            Ok((
                crate::video::VideoFrame {
                    index: i,
                    time_s,
                    pixels,
                },
                view,
            ))
        })
        .collect::<Result<Vec<_>, _>>()
        .map(|pairs| pairs.into_iter().unzip())
}

/// The body posed by `pose`, seen by `camera`, coloured by `colour` of each pixel's rest-surface
/// point: [`Subject::bare`] drawn by [`Subject::photo`].
pub fn photo(
    body: &BodyModel,
    pose: &BodyPose,
    camera: &Camera,
    colour: impl Fn(Vec3) -> [f32; 3],
) -> Result<RgbaImage, PoseError> {
    Subject::bare(body).photo(pose, camera, |p, _| colour(p))
}

/// What a point of a synthetic subject is, for its colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Material {
    Skin,
    Cloth,
    Hair,
    Teeth,
}

/// A mesh carried rigidly by one joint of the body (hair), in the body's rest space.
#[derive(Clone, Debug)]
pub struct Rigid {
    pub joint: usize,
    pub vertices: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

/// A synthetic person with known geometry: the body, clothing that stands off it along its normals
/// (a displacement per vertex, 0 for bare skin), and hair as a mesh of its own riding the head.
/// Drawn from any camera in any pose it is the ground truth a reconstruction from one of its
/// photos is measured against.
#[derive(Clone, Debug)]
pub struct Subject<'a> {
    pub name: &'static str,
    pub body: &'a BodyModel,
    /// Metres along the posed normal, per body vertex; empty for none.
    pub clothing: Vec<f32>,
    pub hair: Option<Rigid>,
}

/// Photos are drawn this many times finer and box-filtered, so their edges are antialiased as a
/// camera's are.
const SUPERSAMPLE: u32 = 3;

impl<'a> Subject<'a> {
    pub fn bare(body: &'a BodyModel) -> Self {
        Self {
            name: "bare",
            body,
            clothing: Vec::new(),
            hair: None,
        }
    }

    /// The body in a jacket: torso and arms 2.5 cm out, hips 3 cm, and a hem that flares to
    /// 6 cm off the thighs 12 cm below the hips and ends there.
    pub fn clothed(body: &'a BodyModel) -> Self {
        Self {
            name: "clothed",
            clothing: jacket(body),
            ..Self::bare(body)
        }
    }

    /// The body with a hair volume over the top and back of its head (up to 5 cm thick).
    pub fn haired(body: &'a BodyModel) -> Self {
        Self {
            name: "haired",
            hair: hair_volume(body),
            ..Self::bare(body)
        }
    }

    /// The hair volume and hair hanging from it to the shoulders, beside and behind the neck:
    /// what a front photo shows only as a strip beside the neck, and a side or back view shows
    /// whole.
    pub fn long_haired(body: &'a BodyModel) -> Self {
        Self {
            name: "long-haired",
            hair: hair_volume(body).zip(hanging_hair(body)).map(|(mut v, h)| {
                let base = v.vertices.len() as u32;
                v.vertices.extend(h.vertices);
                v.triangles
                    .extend(h.triangles.iter().map(|t| t.map(|i| i + base)));
                v
            }),
            ..Self::bare(body)
        }
    }

    /// Both.
    pub fn clothed_and_haired(body: &'a BodyModel) -> Self {
        Self {
            name: "clothed and haired",
            clothing: jacket(body),
            hair: hair_volume(body),
            ..Self::bare(body)
        }
    }

    /// Every triangle of the subject posed by `pose` (body first, then hair), with each vertex's
    /// rest point and material.
    fn posed_mesh(&self, pose: &BodyPose) -> Result<PosedMesh, PoseError> {
        let body = self.body;
        let mut posed = PosedBody::default();
        body.pose(pose, &mut posed)?;
        let mut vertices = posed.vertices.clone();
        if !self.clothing.is_empty() {
            let normals = body.normals_of(&posed.vertices);
            for ((v, n), d) in vertices.iter_mut().zip(&normals).zip(&self.clothing) {
                *v += *n * *d;
            }
        }
        let mut rest = body.vertices.clone();
        let mut materials: Vec<Material> = (0..body.vertices.len())
            .map(|v| match self.clothing.get(v) {
                _ if body.part_of(v) == Some("teeth") => Material::Teeth,
                Some(&d) if d > 0.0 => Material::Cloth,
                _ => Material::Skin,
            })
            .collect();
        let mut triangles = body.triangles.clone();
        if let Some(hair) = &self.hair {
            let frame = posed.joints[hair.joint];
            let origin = posed.rest_joints[hair.joint];
            let base = vertices.len() as u32;
            vertices.extend(
                hair.vertices
                    .iter()
                    .map(|&p| frame.transform_point3(p - origin)),
            );
            rest.extend(&hair.vertices);
            materials.extend(hair.vertices.iter().map(|_| Material::Hair));
            triangles.extend(hair.triangles.iter().map(|t| t.map(|i| i + base)));
        }
        Ok(PosedMesh {
            vertices,
            rest,
            materials,
            triangles,
        })
    }

    /// The subject posed by `pose`, seen by `camera`, each pixel coloured by `colour` of its rest
    /// point and material; antialiased, alpha the share of the pixel it covers (straight alpha,
    /// as PNG stores it).
    pub fn photo(
        &self,
        pose: &BodyPose,
        camera: &Camera,
        colour: impl Fn(Vec3, Material) -> [f32; 3],
    ) -> Result<RgbaImage, PoseError> {
        let mesh = self.posed_mesh(pose)?;
        let fine = camera.scaled(SUPERSAMPLE as f32);
        let f = rasterize(&mesh.vertices, &mesh.triangles, &fine);
        let s = SUPERSAMPLE;
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        Ok(RgbaImage::from_fn(camera.width, camera.height, |x, y| {
            let (mut sum, mut covered) = (Vec3::ZERO, 0u32);
            for (fx, fy) in (0..s * s).map(|k| (x * s + k % s, y * s + k / s)) {
                let i = f.index(fx, fy);
                let Ok(t) = usize::try_from(f.triangle[i]) else {
                    continue;
                };
                let tri = mesh.triangles[t];
                let b = f.bary[i];
                let rest: Vec3 = (0..3).map(|k| b[k] * mesh.rest[tri[k] as usize]).sum();
                // The material of the corner the point is nearest.
                let corner = (0..3).fold(0, |m, k| if b[k] > b[m] { k } else { m });
                sum += Vec3::from(colour(rest, mesh.materials[tri[corner] as usize]));
                covered += 1;
            }
            if covered == 0 {
                return Rgba([0, 0, 0, 0]);
            }
            let c = sum / covered as f32;
            Rgba([q(c.x), q(c.y), q(c.z), q(covered as f32 / (s * s) as f32)])
        }))
    }
}

struct PosedMesh {
    vertices: Vec<Vec3>,
    rest: Vec<Vec3>,
    materials: Vec<Material>,
    triangles: Vec<[u32; 3]>,
}

/// Each vertex's most weighted joint's name.
fn dominant_joints(body: &BodyModel) -> Vec<&str> {
    (0..body.vertices.len())
        .map(|v| body.joints[body.dominant_joint(v)].name.as_str())
        .collect()
}

/// [`Subject::clothed`]'s displacements.
fn jacket(body: &BodyModel) -> Vec<f32> {
    let hip_y = body
        .joint_index("upperleg01.L")
        .map_or(0.9, |j| body.joints[j].rest.y);
    const HEM_DROP: f32 = 0.12;
    dominant_joints(body)
        .iter()
        .zip(&body.vertices)
        .map(|(joint, v)| {
            let torso = joint.starts_with("spine")
                || joint.starts_with("clavicle")
                || joint.starts_with("shoulder")
                || joint.starts_with("upperarm")
                || joint.starts_with("lowerarm");
            if torso {
                0.025
            } else if joint.starts_with("pelvis") || *joint == "root" {
                0.03
            } else if joint.starts_with("upperleg01") && v.y > hip_y - HEM_DROP {
                // The flare: from the hips' 3 cm to 6 cm at the hem.
                0.03 + 0.03 * ((hip_y - v.y) / HEM_DROP).clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
        .collect()
}

/// [`Subject::haired`]'s hair: the skin of the head's top and back, from the hairline (at the
/// brow's height in front, the nape behind) out along its normals by up to 5 cm, riding the head.
fn hair_volume(body: &BodyModel) -> Option<Rigid> {
    let head = body.joint_index("head")?;
    let joints = dominant_joints(body);
    let centre = body.joints[head].rest;
    let normals = body.normals_of(&body.vertices);
    // How far into the hair a head vertex is: 0 at the hairline, 1 at the crown and the back.
    let depth = |v: usize| -> f32 {
        let p = body.vertices[v] - centre;
        let front = (p.y - 0.05) / 0.06;
        let back = (-p.z - 0.02) / 0.05 + (p.y + 0.06) / 0.08;
        front.max(back.min(1.0)).clamp(0.0, 1.0)
    };
    let is_scalp =
        |v: usize| joints[v] == "head" && body.part_of(v) == Some("head") && depth(v) > 0.0;
    let mut index = vec![u32::MAX; body.vertices.len()];
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for t in &body.triangles {
        if !t.iter().all(|&v| is_scalp(v as usize)) {
            continue;
        }
        let mapped = t.map(|v| {
            let v = v as usize;
            if index[v] == u32::MAX {
                index[v] = vertices.len() as u32;
                let d = depth(v);
                vertices.push(body.vertices[v] + normals[v] * (0.005 + 0.045 * d * d));
            }
            index[v]
        });
        triangles.push(mapped);
    }
    Some(Rigid {
        joint: head,
        vertices,
        triangles,
    })
}

/// [`Subject::long_haired`]'s hanging hair: a curtain riding the head, from the ears' height to
/// just above the shoulders, round the back of the head and neck from one ear to the other on
/// an ellipse 1.5 cm outside the skull's widest and backmost points.
fn hanging_hair(body: &BodyModel) -> Option<Rigid> {
    let head = body.joint_index("head")?;
    let centre = body.joints[head].rest;
    let skull = (0..body.vertices.len())
        .filter(|&v| body.part_of(v) == Some("head") && body.vertices[v].y > centre.y - 0.02);
    let (half_width, back) = skull.fold((0.0f32, f32::MAX), |(w, b), v| {
        let p = body.vertices[v];
        (w.max((p.x - centre.x).abs()), b.min(p.z))
    });
    // The shoulders' top beside the neck, where the hair ends.
    let shoulders = (0..body.vertices.len())
        .filter(|&v| body.part_of(v) != Some("head"))
        .map(|v| body.vertices[v])
        .filter(|p| p.y < centre.y && ((p.x - centre.x).abs() - half_width).abs() < 0.01)
        .fold(f32::MIN, |top, p| top.max(p.y));
    let (a, b) = (half_width + 0.015, centre.z - back + 0.015);
    let (top, bottom) = (centre.y + 0.04, shoulders + 0.01);
    let (around, down) = (40, 14);
    let mut vertices = Vec::new();
    for i in 0..=down {
        let y = top + (bottom - top) * i as f32 / down as f32;
        for k in 0..=around {
            // From one ear (100° from straight back) round the back to the other.
            let theta = (-100.0 + 200.0 * k as f32 / around as f32).to_radians();
            vertices.push(Vec3::new(
                centre.x + a * theta.sin(),
                y,
                centre.z - b * theta.cos(),
            ));
        }
    }
    let at = |i: u32, k: u32| i * (around + 1) + k;
    let mut triangles = Vec::new();
    for i in 0..down {
        for k in 0..around {
            triangles.push([at(i, k), at(i + 1, k), at(i, k + 1)]);
            triangles.push([at(i, k + 1), at(i + 1, k), at(i + 1, k + 1)]);
        }
    }
    Some(Rigid {
        joint: head,
        vertices,
        triangles,
    })
}

/// Colours of the synthetic subjects: a smooth skin tone, banded cloth and streaked hair, each a
/// function of the rest point so every view and pose of a subject agrees.
pub fn subject_texture(p: Vec3, material: Material) -> [f32; 3] {
    match material {
        Material::Skin => [
            0.80 + 0.08 * (5.0 * p.y).sin(),
            0.60 + 0.06 * (4.0 * p.x + 1.0).sin(),
            0.50 + 0.05 * (3.0 * p.z).cos(),
        ],
        Material::Cloth => [
            0.20 + 0.15 * (14.0 * p.y + 3.0 * p.x).sin(),
            0.35 + 0.2 * (11.0 * p.x - 6.0 * p.z).sin(),
            0.60 + 0.25 * (9.0 * p.y).cos(),
        ],
        Material::Hair => [
            0.30 + 0.08 * (60.0 * p.x).sin(),
            0.18 + 0.05 * (60.0 * p.x).sin(),
            0.10,
        ],
        // An off-white of natural teeth (about VITA shade A2), not a colour the reconstruction
        // derives its guess from.
        Material::Teeth => [0.86, 0.81, 0.70],
    }
}

/// A family of subject textures for the refiner's training and held-out pairs: each seed draws,
/// per material, a base colour, two bands (direction, spatial frequency 4–60 rad/m, amplitude)
/// and a fine stripe, so that the refiner sees smooth and detailed surfaces in many colours. A
/// function of the rest point, like [`subject_texture`], so every view and pose agrees.
pub fn seeded_texture(seed: u64) -> impl Fn(Vec3, Material) -> [f32; 3] + Clone {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
    let mut next = move || {
        // splitmix64
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f32 / (1u64 << 53) as f32
    };
    let mut material = || {
        let base = [next(), next(), next()].map(|c| 0.12 + 0.76 * c);
        let mut band = |low: f32, high: f32| {
            let dir = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize_or(Vec3::Y);
            let frequency = low + (high - low) * next();
            let amplitude = [next(), next(), next()].map(|a| 0.2 * a);
            (dir * frequency, 6.3 * next(), amplitude)
        };
        (base, [band(4.0, 15.0), band(15.0, 60.0)])
    };
    let materials = [material(), material(), material(), material()];
    move |p: Vec3, m: Material| {
        let (base, bands) = materials[m as usize];
        std::array::from_fn(|c| {
            let wave: f32 = bands
                .iter()
                .map(|(k, phase, amplitude)| amplitude[c] * (k.dot(p) + phase).sin())
                .sum();
            (base[c] + wave).clamp(0.0, 1.0)
        })
    }
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
    let normals = body.normals_of(vertices);
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
    let portrait = image::open(crate::DEMO_PORTRAIT)?.to_rgb8();
    let mut photo = image::RgbImage::from_pixel(size[0], size[1], image::Rgb([150, 150, 160]));
    image::imageops::replace(&mut photo, &portrait, at[0], at[1]);
    Ok(photo)
}
