//! Gaussians for what the body does not explain (hair beyond the scalp, loose clothing, a held
//! object): one for every person-mask pixel of the source view the (dressed) body does not cover,
//! with that pixel's colour, at the depth of the nearest body surface the view does see.
//!
//! Each is skinned by the body around it ([`SkinnedGaussians`]), never bound rigidly to one
//! triangle, as clothed-avatar methods diffuse skinning weights off the body. Which body: cloth
//! between an arm and the torso below the shoulder (a jacket's sides beside a hanging arm) takes
//! the torso's alone, so it stays with the torso when the arm swings instead of flapping with it
//! like a wing (the demo portrait's suit did); elsewhere the nearest vertices, arm or not (a
//! sleeve follows its arm). Hair takes weights over joints diffused from the skull, the neck and
//! the torso around it (never the face, which expressions move, nor the arms), averaged over a
//! window of neighbouring hair pixels, each joint carried by the one vertex that moves most
//! nearly with it alone, the same for all hair, and its depth averaged over the same window
//! (with the vertex nearest each Gaussian instead, neighbours carried by different vertices
//! tore apart across the hair when the head turned: a Gaussian moves by its vertices' mean plus
//! their blended rotation of its offset from it, which depends on where the vertices lie unless
//! they all turn alike); a share of it
//! ([`HAIR_LAG`]), growing from none at the scalp, hangs from the upper torso, as hanging hair
//! lags a turning head. Per pixel, by the body pixel nearest each, long hair tore into cracks
//! along the rows where that jumped from the jaw to the neck. (Cloth keeps its nearest
//! vertices: joints carried by vertices centimetres apart move a Gaussian a little differently
//! from the joints' own blend, which is what a glTF export can express, and the clothing beside
//! the arms would be off by centimetres there.) What lies past the body's reach (a held object)
//! rides the body surface seen beside it, as one piece: each connected part takes the skinning
//! of its pixel nearest the body.
//!
//! Each is a disc facing the source camera, under a pixel wide, and as thick along the view as
//! half its distance from that surface, up to [`MAX_DEPTH`] (thicker, a jacket's edge around the
//! neck stood out as a collar from the side). Hair (what lies near the head) is placed at the
//! head's middle depth instead and stands only [`HAIR_DEPTH`] deep along the view: at the nearest
//! surface's depth, the hair above and beside the face was a flat brim in front of the forehead
//! seen from the side, and deeper discs drew horizontal streaks; from the front it looks the same
//! either way.

use glam::{Mat3A, Vec3};

use crate::avatar::{SkinnedGaussians, blend, quat_from_matrix, quat_mul};
use crate::body::{BodyModel, PosedBody, TargetGroup};
use crate::camera::Camera;
use crate::photo::SourceImage;
use crate::photo::distance::{connected_parts, nearest_seeds};
use crate::raster::Fragments;

use super::hair;
use super::hanging::{self, Strand};

/// The thickest an extra Gaussian stands along the view (standard deviation, metres).
pub const MAX_DEPTH: f32 = 0.01;
/// How deep hair stands along the view (standard deviation, metres): three of it reach from the
/// head's middle to its front and back.
pub const HAIR_DEPTH: f32 = 0.002;
/// Half the side of the window hair's depth and skinning are averaged over (pixels of the source).
const SMOOTHING: usize = 16;
/// Standard deviation of a disc across the view, in pixels of the source, before the splatting
/// pass's low-pass (compensated for default-mode avatars, `gaussians::LowPass`): at 0.45, which
/// the dilating low-pass needed (at 0.6 neighbours' discs blurred the hair's strands), the
/// compensated one left the hair see-through (the clip's reference frame 29.25 → 27.74 dB); 0.6
/// covers it again (29.28), 0.7 and 0.85 blur it (29.23, 28.78).
const RADIUS_PX: f32 = 0.6;
/// Extra Gaussians are opaque where the mask is sure, as the body's discs are.
const OPACITY: f32 = 0.95;
/// A pixel belongs to the person at this mask value.
pub(super) const PERSON: f32 = 0.5;
/// Body vertices a Gaussian is skinned by, at most, and how far they may be (metres); past it
/// the nearest few are taken from further out.
const ANCHORS: usize = 4;
const REACH: f32 = 0.06;
/// The distance falloff of the anchors' weights (metres): those within a few centimetres share
/// the Gaussian about evenly, so it moves with the surface around it, not one vertex.
const FALLOFF: f32 = 0.03;
/// A vertex a face unit moves by more than this (metres) is the face's.
const EXPRESSION_MOVES: f32 = 1e-4;
/// What has a head vertex this near (metres) is hair. Taken from the anchors alone (the head
/// among the four nearest), the hair hanging beside the clip's neck was cloth, skinned by the
/// torso, and stayed behind when her head moved.
const HAIR_REACH: f32 = 2.0 * REACH;
/// The share of hair's skinning taken from the upper torso's joint instead of the body around
/// it, for hair [`HAIR_HANGS_AT`] or more from the head, and less nearer it (a smoothstep from
/// none at the head): hair hangs, and lags the head's turns and tilts, but it grows from the
/// scalp. The same share everywhere opened the hair from the head's side when the head turned:
/// with the head turned 20° and nodded 11°, `fidelity::long_hair_beside_the_neck_stays_whole_
/// when_the_head_turns` counted 0, 15 and 21 holes at 0.15, 0.2 and 0.3 (the shipped clip's
/// self-reenactment from frame 0, `--every 8`: 16.99, 17.06 and 17.14 dB with them, 16.73
/// without, tracked with the joints' filter at 0.5 Hz; at 1 Hz 0.15 scores 17.07). Growing with
/// the distance, none: 0.45 over 3 cm 17.25 dB, 0.6 over 3 cm 17.28 (0.6 over 2 cm: 9 holes;
/// 0.6 over 5 cm: 17.20 dB). 0.45, as the glTF export's linear blend skinning follows the
/// chest's share, carried by a chest vertex, less closely (`export_gltf`: 99th percentile 1.48
/// cm off the viewer's at 0.45, 1.58 at 0.6; bound 1.5). Tuned on the one real clip.
const HAIR_LAG: f32 = 0.45;
const HAIR_HANGS_AT: f32 = 0.03;
/// Cloth this far below the shoulder joint and between the arm and the torso follows the torso.
const BELOW_SHOULDER: f32 = 0.05;

/// The arms' root joints: a vertex skinned mostly to one of these or their descendants (hands
/// and fingers) is an arm's.
const ARM_ROOTS: [&str; 2] = ["upperarm01.L", "upperarm01.R"];
/// Each arm's joints down its length: shoulder, elbow, wrist.
const ARM_CHAINS: [[&str; 3]; 2] = [
    ["upperarm01.L", "lowerarm01.L", "wrist.L"],
    ["upperarm01.R", "lowerarm01.R", "wrist.R"],
];

/// Extra Gaussians for `photo`'s person pixels that `fragments` (the posed body's
/// rasterization from `camera`, the photo's size) leaves uncovered; `vertices` are the posed
/// body's (dressed, as rasterized) and `posed` its pose (for the skinning). Features: RGB and
/// the mask value as source confidence. With hair standing `hair` metres off the head
/// (`hair::thickness`), the hair hanging beside the neck also goes on behind it
/// ([`hanging::curtain`]).
pub fn extras(
    photo: &SourceImage,
    fragments: &Fragments,
    body: &BodyModel,
    vertices: &[Vec3],
    posed: &PosedBody,
    camera: &Camera,
    hair: f32,
) -> SkinnedGaussians {
    let mut out = SkinnedGaussians::default();
    let Some(mask) = &photo.mask else {
        return out;
    };
    let size = photo.size as usize;
    let covered: Vec<bool> = fragments.triangle.iter().map(|&t| t >= 0).collect();
    let nearest = nearest_seeds(&covered, size);
    let disc = facing_camera(camera);
    let anchors = Anchors::new(body, vertices, posed);
    // The head's middle depth from the camera, where hair is placed.
    let middle = camera
        .view_from_world
        .transform_point3(anchors.head_middle)
        .z;
    let mut found: Vec<Uncovered> = Vec::new();
    for (i, &m) in mask.iter().enumerate() {
        if m < PERSON || covered[i] {
            continue;
        }
        let Some((_, q)) = nearest[i] else { continue };
        let q = q as usize;
        let z = fragments.depth[q];
        let point = camera.unproject((i % size) as f32 + 0.5, (i / size) as f32 + 0.5, z);
        let beside = body.triangles[fragments.triangle[q] as usize];
        let (skinning, held) = match anchors.near(point) {
            Some(skinning) => (skinning, false),
            None => match anchors.beside(point, &beside) {
                Some(skinning) => (skinning, true),
                None => continue,
            },
        };
        let hair = anchors.to_head(point);
        found.push(Uncovered {
            pixel: i,
            nearest: q,
            depth: z,
            skinning,
            held,
            hair,
        });
    }
    // Hair's depth and skinning, smoothed across the hair. Each pixel's nearest body pixel
    // jumps, between the jaw's outline and the neck's say, centimetres apart in depth and with
    // other vertices around it, and neighbouring pixels placed and skinned by those jumps tore
    // apart into black cracks as soon as the head turned or nodded. So hair's depth is averaged
    // over a window, and its skinning taken as weights over joints (diffused from the skull,
    // neck and torso around it) averaged over the same window. (Cloth placed so, the demo
    // portrait's suit showed dark shards under her raised arm, and scored 0.6 dB less.)
    let unproject =
        |i: usize, z: f32| camera.unproject((i % size) as f32 + 0.5, (i / size) as f32 + 0.5, z);
    let is_hair = |u: &Uncovered| u.hair.is_some() && !u.held;
    let mut inside = vec![false; size * size];
    for u in found.iter().filter(|u| is_hair(u)) {
        inside[u.pixel] = true;
    }
    let window = Window::new(&inside, size, SMOOTHING);
    // `found` is in pixel order, as the window's pixels are.
    let depths: Vec<f32> = found
        .iter()
        .filter(|u| is_hair(u))
        .map(|u| middle.max(u.depth))
        .collect();
    let depths = window.means(&depths);
    let lags = found
        .iter()
        .filter_map(|u| is_hair(u).then_some(u.hair).flatten())
        .map(hair_lag);
    let weights: Vec<Vec<(u16, f32)>> = window
        .pixels
        .iter()
        .zip(&depths)
        .zip(lags)
        .map(|((&i, &z), lag)| anchors.hair_joints(unproject(i, z), lag))
        .collect();
    let mut smoothed = depths.into_iter().zip(window.mean_weights(&weights));
    let mut placed: Vec<(usize, Vec3, Skinning, bool, Extra)> = Vec::new();
    let mut strands: Vec<Strand> = Vec::new();
    for u in found {
        let (i, z) = (u.pixel, u.depth);
        let m = mask[i];
        let features = photo.straight(i);
        let (point, skinning, along, z) = if is_hair(&u) {
            let (depth, joints) = smoothed.next().expect("one per hair pixel");
            let point = unproject(i, depth);
            strands.push(Strand {
                pixel: i,
                point,
                rgb: features,
            });
            match anchors.by_joints(&joints) {
                Some(skinning) => (point, skinning, HAIR_DEPTH, depth),
                None => continue,
            }
        } else {
            // As thick along the view as half the way to the body beside it.
            let point = unproject(i, z);
            let along = 0.5 * point.distance(unproject(u.nearest, z));
            (point, u.skinning, along, z)
        };
        let across = RADIUS_PX * camera.pixel_footprint(z);
        let along = along.clamp(across, MAX_DEPTH);
        let gaussian = Extra {
            scale: [across, along, across],
            opacity: OPACITY * m.min(1.0),
            features: [features[0], features[1], features[2], m.min(1.0)],
        };
        placed.push((i, point, skinning, u.held, gaussian));
    }
    // A held object moves as one piece: each connected part of what rides the surface beside
    // it takes the skinning of its pixel nearest the body. Pixel by pixel, by the surface seen
    // nearest each, the demo portrait's helmet tore across when she moved (its top rode her
    // arm, its bottom her hip).
    let mut held = vec![false; size * size];
    for &(i, .., is_held, _) in &placed {
        held[i] = is_held;
    }
    let (part, parts) = connected_parts(&held, size);
    let mut attached: Vec<Option<(f32, Skinning)>> = vec![None; parts.len()];
    for &(i, _, skinning, is_held, _) in &placed {
        let (Some((distance, _)), true) = (nearest[i], is_held) else {
            continue;
        };
        let slot = &mut attached[part[i] as usize];
        if slot.is_none_or(|(d, _)| distance < d) {
            *slot = Some((distance, skinning));
        }
    }
    let cloth: Vec<(usize, [f32; 3])> = placed
        .iter()
        .filter(|&&(i, _, _, is_held, _)| !is_held && !inside[i])
        .map(|(i, _, _, _, g)| (*i, [g.features[0], g.features[1], g.features[2]]))
        .collect();
    for (i, point, skinning, is_held, gaussian) in placed {
        let skinning = match (is_held, attached.get(part[i] as usize)) {
            (true, Some(Some((_, one)))) => *one,
            _ => skinning,
        };
        push(&mut out, point, skinning, disc, &gaussian, vertices, posed);
    }
    // The body's far side from the camera, rasterized once for the cloth's back and the hair
    // behind the neck, and only when either asks.
    let far = std::cell::OnceCell::new();
    let far_side = || {
        far.get_or_init(|| crate::raster::farthest(vertices, &body.triangles, camera))
            .as_slice()
    };
    cloth_back(
        &mut out, photo, &cloth, &covered, &nearest, &anchors, camera, posed, far_side,
    );
    if hair > 0.0 {
        hang_behind(
            &mut out, &strands, &anchors, camera, fragments, hair, posed, far_side,
        );
    }
    out
}

/// The cloth's back: one disc for each [`BACK_STRIDE`]² pixels of cloth beyond the body, at the
/// depth of the body's far side at the body pixel nearest it, in the median colour of the cloth
/// within [`BACK_WINDOW`] of it.
const BACK_STRIDE: usize = 2;
const BACK_WINDOW: f32 = 0.09;
/// At most this many pixels a side of the window go into its median (the rest skipped evenly).
const BACK_SAMPLES: usize = 24;
/// The discs in one cell of this many pixels a side share their window's median.
const BACK_CELL: usize = 8;

/// Appends the back of the cloth beyond the body: a flat disc of the photo's colour looks the
/// same from behind, so seen from the back the cloth beside the body showed the front's print (a
/// badge, a name tag) as a cut-out. Behind each [`BACK_STRIDE`]² block of the `cloth` pixels (with
/// their colours; `nearest` gives each pixel's nearest body pixel) a disc stands at the body's far
/// side there, in the median colour of the cloth around it less the prints on it (found on the
/// whole person in `photo`, [`super::behind::prints`]: the cloth's colour comes through, a badge
/// does not, as the body's back takes it), skinned by the body near it. (The median alone, where
/// half of the cloth beside the demo portrait's body was her badge, put a purple smear on her
/// back.)
#[allow(clippy::too_many_arguments)]
fn cloth_back<'a>(
    out: &mut SkinnedGaussians,
    photo: &SourceImage,
    cloth: &[(usize, [f32; 3])],
    covered: &[bool],
    nearest: &[Option<(f32, u32)>],
    anchors: &Anchors,
    camera: &Camera,
    posed: &PosedBody,
    far_side: impl FnOnce() -> &'a [f32],
) {
    if cloth.is_empty() {
        return;
    }
    let size = camera.width as usize;
    let disc = facing_camera(camera);
    let far = far_side();
    let cells = size.div_ceil(BACK_CELL);
    let mut medians: Vec<Option<Option<[f32; 3]>>> = vec![None; cells * cells];
    let mut colour: Vec<Option<[f32; 3]>> = vec![None; size * size];
    for &(i, c) in cloth {
        colour[i] = Some(c);
    }
    let print = prints_on(photo, cloth, nearest, far, camera);
    for &(i, _) in cloth {
        let (x, y) = (i % size, i / size);
        if x % BACK_STRIDE != 0 || y % BACK_STRIDE != 0 {
            continue;
        }
        // Only where the person covers the disc's footprint in the photo: at the outline it
        // would widen the source view's silhouette.
        let r = BACK_STRIDE;
        let inside = x >= r && y >= r && x + r < size && y + r < size;
        let hidden = inside
            && (y - r..=y + r).all(|wy| {
                (x - r..=x + r)
                    .all(|wx| covered[wy * size + wx] || colour[wy * size + wx].is_some())
            });
        if !hidden {
            continue;
        }
        let Some((_, q)) = nearest[i] else { continue };
        let z = far[q as usize];
        if !z.is_finite() {
            continue;
        }
        let point = camera.unproject(x as f32 + 0.5, y as f32 + 0.5, z);
        let Some(skinning) = anchors.near(point) else {
            continue;
        };
        // The window's median, shared by the discs of one cell (their windows differ by a
        // cell in ~[`BACK_WINDOW`]).
        let cell = (y / BACK_CELL) * cells + x / BACK_CELL;
        let rgb = *medians[cell].get_or_insert_with(|| {
            let (cx, cy) = (
                (x / BACK_CELL) * BACK_CELL + BACK_CELL / 2,
                (y / BACK_CELL) * BACK_CELL + BACK_CELL / 2,
            );
            let radius = (BACK_WINDOW / camera.pixel_footprint(z)) as usize;
            let step = (2 * radius / BACK_SAMPLES).max(1);
            let mut around = Vec::new();
            for wy in (cy.saturating_sub(radius)..(cy + radius + 1).min(size)).step_by(step) {
                for wx in (cx.saturating_sub(radius)..(cx + radius + 1).min(size)).step_by(step) {
                    let k = wy * size + wx;
                    around.extend(colour[k].map(|c| (c, print[k])));
                }
            }
            super::behind::cloth_median(around)
        });
        let Some(rgb) = rgb.or(colour[i]) else {
            continue;
        };
        // As wide as the block of pixels it stands for, and as thick.
        let across = BACK_STRIDE as f32 * RADIUS_PX * camera.pixel_footprint(z);
        let extra = Extra {
            scale: [across, across.min(MAX_DEPTH), across],
            opacity: OPACITY,
            features: [rgb[0], rgb[1], rgb[2], 0.0],
        };
        push(out, point, skinning, disc, &extra, anchors.vertices, posed);
    }
}

/// Per pixel of `photo`: whether it lies in a print on the person's clothes
/// ([`super::behind::prints`], over the person's pixels), the print's largest area in pixels at
/// the median depth of the far side behind the `cloth` pixels (`far`, by their `nearest` body
/// pixels).
fn prints_on(
    photo: &SourceImage,
    cloth: &[(usize, [f32; 3])],
    nearest: &[Option<(f32, u32)>],
    far: &[f32],
    camera: &Camera,
) -> Vec<bool> {
    let size = camera.width as usize;
    let mut depths: Vec<f32> = cloth
        .iter()
        .filter_map(|&(i, _)| Some(far[nearest[i]?.1 as usize]))
        .filter(|z| z.is_finite())
        .collect();
    if depths.is_empty() {
        return vec![false; size * size];
    }
    let mid = depths.len() / 2;
    let z = *depths.select_nth_unstable_by(mid, f32::total_cmp).1;
    let area = super::behind::PRINT_AREA / camera.pixel_footprint(z).powi(2);
    let person: Vec<Option<[f32; 3]>> = (0..size * size)
        .map(|i| (photo.pixel(i).1 >= PERSON).then(|| photo.straight(i)))
        .collect();
    super::behind::prints(&person, size, size, area as usize)
}

/// A disc facing `camera`: across the view (camera x and y), thin along it (axis 1 is the thin
/// one, as for the surface discs); columns (x, z, −y) keep it right-handed.
fn facing_camera(camera: &Camera) -> [f32; 4] {
    let world_from_view = Mat3A::from_mat4(camera.view_from_world.inverse());
    quat_from_matrix(
        world_from_view * Mat3A::from_cols(Vec3::X.into(), Vec3::Z.into(), (-Vec3::Y).into()),
    )
}

/// How far apart the discs of the hair behind the neck are (metres): it shows no detail of its
/// own, one colour a height.
const CURTAIN_SPACING: f32 = 0.004;

/// Appends the hair hanging behind the neck ([`hanging::curtain`]) for the hair `strands` beside
/// it, each disc skinned as hair there is and kept only where the photo's camera sees the body
/// (`fragments`) or those strands in front of it, so the photo's view keeps what it shows.
#[allow(clippy::too_many_arguments)]
fn hang_behind<'a>(
    out: &mut SkinnedGaussians,
    strands: &[Strand],
    anchors: &Anchors,
    camera: &Camera,
    fragments: &Fragments,
    hair: f32,
    posed: &PosedBody,
    far_side: impl FnOnce() -> &'a [f32],
) {
    let Some(head) = anchors.body.joint_index("head") else {
        return;
    };
    let joint: Vec3 = posed.joints[head].translation.into();
    let below_skull = camera.project(joint - Vec3::Y * hair::SKULL_BELOW);
    let depth = |p: Vec3| camera.view_from_world.transform_point3(p).z;
    let size = camera.width as usize;
    let discs = hanging::curtain(
        strands,
        size,
        camera,
        below_skull.y.max(0.0) as usize,
        camera.project(joint).x,
        far_side,
        hair,
        CURTAIN_SPACING,
    );
    // What the photo's camera sees in front at each pixel: the body, or the discs beyond it.
    let mut front: Vec<Option<f32>> = (0..size * size)
        .map(|i| (fragments.triangle[i] >= 0).then_some(fragments.depth[i]))
        .collect();
    for s in strands {
        let z = depth(s.point);
        front[s.pixel] = Some(front[s.pixel].map_or(z, |f| f.min(z)));
    }
    let across = 0.6 * CURTAIN_SPACING;
    for d in discs {
        if !hair::hidden(camera, d.point, across, |i| front[i]) {
            continue;
        }
        let to_head = anchors.to_head(d.point).unwrap_or(HAIR_HANGS_AT);
        let joints = anchors.hair_joints(d.point, hair_lag(to_head));
        let Some(skinning) = anchors.by_joints(&joints) else {
            continue;
        };
        let extra = Extra {
            scale: [across, HAIR_DEPTH, across],
            opacity: OPACITY,
            features: [d.rgb[0], d.rgb[1], d.rgb[2], 0.0],
        };
        push(
            out,
            d.point,
            skinning,
            facing(d.normal),
            &extra,
            anchors.vertices,
            posed,
        );
    }
}

/// The share of hair's skinning moved to the upper torso's joint for hair `to_head` metres from
/// the head ([`HAIR_LAG`]).
fn hair_lag(to_head: f32) -> f32 {
    let t = (to_head / HAIR_HANGS_AT).clamp(0.0, 1.0);
    HAIR_LAG * t * t * (3.0 - 2.0 * t)
}

/// The anchors' weight at distance `d` (before normalising).
fn falloff(d: f32) -> f32 {
    (-0.5 * (d / FALLOFF).powi(2)).exp().max(1e-6)
}

/// [`falloff`] brought to nothing at `reach`, so that a vertex coming into reach adds to the
/// weights from zero instead of by a step.
fn tapered(d: f32, reach: f32) -> f32 {
    (falloff(d) - falloff(reach)).max(1e-6)
}

/// Means over a square window of the pixels of a mask (`inside`, `size`²), by summed-area
/// tables over the box holding the mask.
struct Window {
    size: usize,
    radius: usize,
    /// The box: left, top, width, height.
    bounds: [usize; 4],
    /// The mask's pixels, row-major.
    pixels: Vec<usize>,
    /// How many of them each window holds, by pixel of `pixels`.
    counts: Vec<u32>,
}

impl Window {
    fn new(inside: &[bool], size: usize, radius: usize) -> Self {
        let pixels: Vec<usize> = (0..inside.len()).filter(|&i| inside[i]).collect();
        let (mut x0, mut y0, mut x1, mut y1) = (size, size, 0, 0);
        for &i in &pixels {
            let (x, y) = (i % size, i / size);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
        }
        let mut window = Self {
            size,
            radius,
            bounds: [x0, y0, x1.saturating_sub(x0), y1.saturating_sub(y0)],
            pixels,
            counts: Vec::new(),
        };
        let ones = vec![1.0; window.pixels.len()];
        window.counts = window.sums(&ones).iter().map(|&c| c as u32).collect();
        window
    }

    /// The window sums of `values` (one per pixel of the mask), at each pixel of the mask.
    fn sums(&self, values: &[f32]) -> Vec<f64> {
        let [x0, y0, w, h] = self.bounds;
        let n = w + 1;
        let mut table = vec![0.0f64; n * (h + 1)];
        for (&i, &v) in self.pixels.iter().zip(values) {
            table[(i / self.size - y0 + 1) * n + i % self.size - x0 + 1] = f64::from(v);
        }
        for y in 1..=h {
            for x in 1..=w {
                let k = y * n + x;
                table[k] += table[k - 1] + table[k - n] - table[k - n - 1];
            }
        }
        let r = self.radius;
        let at = |x: usize, y: usize| table[y * n + x];
        self.pixels
            .iter()
            .map(|&i| {
                let (x, y) = (i % self.size - x0, i / self.size - y0);
                let (a, b) = (x.saturating_sub(r), y.saturating_sub(r));
                let (c, d) = ((x + r + 1).min(w), (y + r + 1).min(h));
                at(c, d) - at(a, d) - at(c, b) + at(a, b)
            })
            .collect()
    }

    /// The window means of `values` (one per pixel of the mask).
    fn means(&self, values: &[f32]) -> Vec<f32> {
        let sums = self.sums(values);
        sums.iter()
            .zip(&self.counts)
            .map(|(s, &c)| (s / f64::from(c.max(1))) as f32)
            .collect()
    }

    /// [`Window::means`] of sparse joint weights, joint by joint.
    fn mean_weights(&self, weights: &[Vec<(u16, f32)>]) -> Vec<Vec<(u16, f32)>> {
        let mut used: Vec<u16> = weights.iter().flatten().map(|&(j, _)| j).collect();
        used.sort_unstable();
        used.dedup();
        let mut out: Vec<Vec<(u16, f32)>> = vec![Vec::new(); weights.len()];
        for &j in &used {
            let plane: Vec<f32> = weights
                .iter()
                .map(|w| w.iter().find(|(k, _)| *k == j).map_or(0.0, |&(_, w)| w))
                .collect();
            for (o, w) in out.iter_mut().zip(self.means(&plane)) {
                if w > 0.0 {
                    o.push((j, w));
                }
            }
        }
        out
    }
}

/// Body vertices that skin a point and their weights (summing to 1).
type Skinning = ([u32; 4], [f32; 4]);

/// A person pixel the body leaves uncovered: the body pixel nearest it and the depth there,
/// what skins it there, whether it rides the surface beside it (a held object, past the body's
/// reach) and whether it is hair (the head within [`HAIR_REACH`]).
struct Uncovered {
    pixel: usize,
    nearest: usize,
    depth: f32,
    skinning: Skinning,
    held: bool,
    /// Hair: how far the nearest head vertex is (metres, within [`HAIR_REACH`]).
    hair: Option<f32>,
}

/// What an extra Gaussian is besides where: its scale (metres), opacity and features.
pub(super) struct Extra {
    pub(super) scale: [f32; 3],
    pub(super) opacity: f32,
    pub(super) features: [f32; 4],
}

/// The rotation of a disc facing along `normal`: its thin axis (the second) along it.
pub(super) fn facing(normal: Vec3) -> [f32; 4] {
    let tangent = normal.any_orthonormal_vector();
    quat_from_matrix(Mat3A::from_cols(
        tangent.into(),
        normal.into(),
        tangent.cross(normal).into(),
    ))
}

/// Appends `extra` at `point` with `rotation` in the world, skinned by `(v, w)`; nothing where
/// their blended skinning is degenerate.
pub(super) fn push(
    out: &mut SkinnedGaussians,
    point: Vec3,
    (v, w): ([u32; 4], [f32; 4]),
    rotation: [f32; 4],
    extra: &Extra,
    vertices: &[Vec3],
    posed: &PosedBody,
) {
    let (anchor, skin) = blend(&v, &w, vertices, posed);
    let det = skin.determinant();
    if !(det.is_finite() && det.abs() > 1e-6) {
        return;
    }
    let turn = quat_from_matrix(skin);
    let inverse = [turn[0], -turn[1], -turn[2], -turn[3]];
    out.vertices.push(v);
    out.weights.push(w);
    out.offsets
        .push((skin.inverse() * (point - anchor)).to_array());
    out.local.rotations.push(quat_mul(inverse, rotation));
    out.local.scales.push(extra.scale);
    out.local.opacities.push(extra.opacity);
    out.local.features.extend(extra.features);
}

/// Which body vertices skin a point beyond the body: the posed vertices in a grid, which of
/// them are an arm's, and where the shoulders and the torso are.
struct Anchors<'a> {
    vertices: &'a [Vec3],
    grid: Grid,
    arm: Vec<bool>,
    /// Which vertices are the head's, and their middle (posed).
    head: Vec<bool>,
    head_middle: Vec3,
    body: &'a BodyModel,
    /// Which vertices hair may hang from ([`Anchors::hair_joints`]), and per joint the vertex
    /// (not the face's) that moves most nearly with it alone: the largest weight for it.
    hangs_from: Vec<bool>,
    carrier: Vec<Option<u32>>,
    /// The torso's spine joint (hair partly hangs from it, [`HAIR_LAG`]), its frame (posed) and
    /// each arm's shoulder, elbow and wrist in it.
    spine: u16,
    torso_from_world: glam::Affine3A,
    arms: Vec<[Vec3; 3]>,
}

/// The grid's cell (metres): a query within [`REACH`] looks at 27 cells.
const CELL: f32 = REACH;
/// One vertex in this many may anchor (about one every 2 cm on the default body): skinning
/// weights vary smoothly over a few centimetres, and the full mesh made the search ten times
/// slower than the rest of the stage.
const ANCHOR_STRIDE: usize = 4;

/// Vertices by the cell of a dense grid over their bounding box (the cells' vertices one after
/// another, as compressed sparse rows): a hashed grid's lookups took most of a second per
/// photo.
struct Grid {
    origin: Vec3,
    dims: [i32; 3],
    starts: Vec<u32>,
    members: Vec<u32>,
}

impl Grid {
    fn new(vertices: &[Vec3]) -> Self {
        let (lo, hi) = vertices
            .iter()
            .filter(|v| v.is_finite())
            .fold((Vec3::MAX, Vec3::MIN), |(lo, hi), v| {
                (lo.min(*v), hi.max(*v))
            });
        let (lo, hi) = if lo.x <= hi.x {
            (lo, hi)
        } else {
            (Vec3::ZERO, Vec3::ZERO)
        };
        let dims = (((hi - lo) / CELL).floor().as_ivec3() + 1).to_array();
        let mut grid = Self {
            origin: lo,
            dims,
            starts: vec![0; (dims[0] * dims[1] * dims[2]) as usize + 1],
            members: Vec::new(),
        };
        let cells: Vec<Option<usize>> = vertices
            .iter()
            .enumerate()
            .map(|(k, v)| match k % ANCHOR_STRIDE {
                0 => grid.index(grid.cell(*v)),
                _ => None,
            })
            .collect();
        for c in cells.iter().flatten() {
            grid.starts[c + 1] += 1;
        }
        for k in 1..grid.starts.len() {
            grid.starts[k] += grid.starts[k - 1];
        }
        let mut next = grid.starts.clone();
        grid.members = vec![0; grid.starts[grid.starts.len() - 1] as usize];
        for (k, c) in cells.iter().enumerate() {
            if let Some(c) = c {
                grid.members[next[*c] as usize] = k as u32;
                next[*c] += 1;
            }
        }
        grid
    }

    fn cell(&self, v: Vec3) -> [i32; 3] {
        ((v - self.origin) / CELL).floor().as_ivec3().to_array()
    }

    fn index(&self, c: [i32; 3]) -> Option<usize> {
        let inside = (0..3).all(|a| (0..self.dims[a]).contains(&c[a]));
        inside.then(|| ((c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]) as usize)
    }

    fn cell_members(&self, c: [i32; 3]) -> &[u32] {
        match self.index(c) {
            Some(i) => &self.members[self.starts[i] as usize..self.starts[i + 1] as usize],
            None => &[],
        }
    }
}

impl<'a> Anchors<'a> {
    fn new(body: &'a BodyModel, vertices: &'a [Vec3], posed: &PosedBody) -> Self {
        let grid = Grid::new(vertices);
        // Joints in an arm: the roots and everything below them.
        let in_arm: Vec<bool> = (0..body.joints.len())
            .map(|mut j| {
                loop {
                    if ARM_ROOTS.contains(&body.joints[j].name.as_str()) {
                        break true;
                    }
                    match body.joints[j].parent {
                        Some(p) if p != j => j = p,
                        _ => break false,
                    }
                }
            })
            .collect();
        let arm: Vec<bool> = body
            .skin_joints
            .iter()
            .zip(&body.skin_weights)
            .map(|(joints, weights)| {
                let arm_share: f32 = joints
                    .iter()
                    .zip(weights)
                    .filter(|(j, _)| in_arm.get(**j as usize).copied().unwrap_or(false))
                    .map(|(_, w)| w)
                    .sum();
                arm_share > 0.5
            })
            .collect();
        let spine = ["spine01", "spine02", "spine03", "root"]
            .iter()
            .find_map(|n| body.joint_index(n))
            .unwrap_or(0);
        let torso_from_world = posed
            .joints
            .get(spine)
            .map_or(glam::Affine3A::IDENTITY, |j| j.inverse());
        let arms = ARM_CHAINS
            .iter()
            .filter_map(|chain| {
                let at = |n: &str| {
                    let j = posed.joints.get(body.joint_index(n)?)?;
                    Some(torso_from_world.transform_point3(j.translation.into()))
                };
                Some([at(chain[0])?, at(chain[1])?, at(chain[2])?])
            })
            .collect();
        let head: Vec<bool> = (0..vertices.len())
            .map(|k| body.part_of(k) == Some("head"))
            .collect();
        // Vertices a face unit moves (the face, the jaw): hair does not follow expressions.
        let mut expressive = vec![false; vertices.len()];
        for (_, t) in body.targets_in(TargetGroup::Expression) {
            for (&v, d) in t.vertices.iter().zip(&t.deltas) {
                expressive[v as usize] |= d.length() > EXPRESSION_MOVES;
            }
        }
        let hangs_from: Vec<bool> = (0..vertices.len())
            .map(|k| !expressive[k] && !arm[k])
            .collect();
        let mut carrier: Vec<Option<(f32, u32)>> = vec![None; body.joints.len()];
        for k in (0..vertices.len()).filter(|&k| !expressive[k]) {
            for (&j, &w) in body.skin_joints[k].iter().zip(&body.skin_weights[k]) {
                let best = &mut carrier[j as usize];
                if w > 0.0 && best.is_none_or(|(most, _)| w > most) {
                    *best = Some((w, k as u32));
                }
            }
        }
        let (sum, count) = vertices
            .iter()
            .zip(&head)
            .filter(|(_, h)| **h)
            .fold((Vec3::ZERO, 0usize), |(s, n), (v, _)| (s + *v, n + 1));
        Self {
            body,
            hangs_from,
            carrier: carrier.into_iter().map(|c| c.map(|(_, k)| k)).collect(),
            vertices,
            grid,
            arm,
            head,
            head_middle: sum / count.max(1) as f32,
            spine: spine as u16,
            torso_from_world,
            arms,
        }
    }

    /// How far the head is from `point` (its nearest anchoring vertex), within [`HAIR_REACH`].
    fn to_head(&self, point: Vec3) -> Option<f32> {
        self.within(point, HAIR_REACH)
            .into_iter()
            .filter(|&(_, k)| self.head[k as usize])
            .map(|(d, _)| d)
            .min_by(f32::total_cmp)
    }

    /// Up to [`ANCHORS`] vertices near `point` and their weights (summing to 1): within
    /// [`REACH`], else three times as far; `None` past that.
    fn near(&self, point: Vec3) -> Option<Skinning> {
        self.weighted(point, self.reached(point, |_| true))
    }

    /// The vertices `keep` allows within [`REACH`] of `point`, else within three times as far,
    /// with their distances.
    fn reached(&self, point: Vec3, keep: impl Fn(u32) -> bool) -> Vec<(f32, u32)> {
        let kept = |radius: f32| -> Vec<(f32, u32)> {
            self.within(point, radius)
                .into_iter()
                .filter(|&(_, k)| keep(k))
                .collect()
        };
        let near = kept(REACH);
        match near.is_empty() {
            true => kept(3.0 * REACH),
            false => near,
        }
    }

    /// The corners of the body surface seen nearest the point's pixel (`beside`): what a held
    /// object, such as the demo portrait's helmet 40 cm from her arm, rides.
    fn beside(&self, point: Vec3, beside: &[u32]) -> Option<Skinning> {
        let corners = beside
            .iter()
            .map(|&k| (self.vertices[k as usize].distance(point), k))
            .collect();
        self.weighted(point, corners)
    }

    /// The nearest [`ANCHORS`] of `near` (vertices with their distances from `point`; the
    /// torso's alone under an arm), weighted by distance.
    fn weighted(&self, point: Vec3, mut near: Vec<(f32, u32)>) -> Option<Skinning> {
        if near.is_empty() {
            return None;
        }
        if self.under_arm(point, &near) {
            let torso: Vec<(f32, u32)> = near
                .iter()
                .copied()
                .filter(|&(_, k)| !self.arm[k as usize])
                .collect();
            if !torso.is_empty() {
                near = torso;
            }
        }
        near.sort_by(|a, b| a.0.total_cmp(&b.0));
        near.truncate(ANCHORS);
        let total: f32 = near.iter().map(|&(d, _)| falloff(d)).sum();
        let (mut v, mut w) = ([near[0].1; 4], [0.0; 4]);
        for (slot, &(d, k)) in near.iter().enumerate() {
            v[slot] = k;
            w[slot] = falloff(d) / total;
        }
        Some((v, w))
    }

    /// Joint weights for hair at `point`: the skinning weights of the body vertices hair may
    /// hang from near it (the skull, the neck, the torso; not the face, which expressions move,
    /// nor the arms), averaged with the anchors' distance falloff tapered to nothing at the
    /// reach they were found in, with `lag` of it moved to the upper torso's joint.
    fn hair_joints(&self, point: Vec3, lag: f32) -> Vec<(u16, f32)> {
        let near = self.reached(point, |k| self.hangs_from[k as usize]);
        let reach = match near.iter().all(|&(d, _)| d <= REACH) {
            true => REACH,
            false => 3.0 * REACH,
        };
        let total: f32 = near.iter().map(|&(d, _)| tapered(d, reach)).sum();
        let mut joints = self.joints_of(
            near.into_iter()
                .map(|(d, k)| (k, (1.0 - lag) * tapered(d, reach) / total)),
        );
        match joints.iter_mut().find(|(j, _)| *j == self.spine) {
            Some((_, w)) => *w += lag,
            None => joints.push((self.spine, lag)),
        }
        joints
    }

    /// The joint weights vertices `(k, share)` amount to: Σ share · k's skinning weights.
    fn joints_of(&self, vertices: impl IntoIterator<Item = (u32, f32)>) -> Vec<(u16, f32)> {
        let mut out: Vec<(u16, f32)> = Vec::new();
        for (k, share) in vertices {
            let k = k as usize;
            let weights = self.body.skin_joints[k]
                .iter()
                .zip(&self.body.skin_weights[k]);
            for (&j, &w) in weights {
                match out.iter_mut().find(|(o, _)| *o == j) {
                    Some((_, sum)) => *sum += share * w,
                    None if w > 0.0 => out.push((j, share * w)),
                    None => {}
                }
            }
        }
        out
    }

    /// A skinning for joint weights: the [`ANCHORS`] heaviest joints, each carried by its
    /// vertex, less the next joint's weight, so that one joint overtaking another changes the
    /// weights by nothing at the crossing (cut off, it took its whole share at once).
    fn by_joints(&self, joints: &[(u16, f32)]) -> Option<Skinning> {
        let mut joints: Vec<(u32, f32)> = joints
            .iter()
            .filter(|&&(_, w)| w > 0.0)
            .filter_map(|&(j, w)| Some((self.carrier[j as usize]?, w)))
            .collect();
        joints.sort_by(|a, b| b.1.total_cmp(&a.1));
        let next = joints.get(ANCHORS).map_or(0.0, |&(_, w)| w);
        joints.truncate(ANCHORS);
        joints.retain(|&(_, w)| w > next);
        let total: f32 = joints.iter().map(|&(_, w)| w - next).sum();
        if joints.is_empty() || total <= 0.0 {
            return None;
        }
        let (mut v, mut w) = ([joints[0].0; 4], [0.0; 4]);
        for (slot, &(k, weight)) in joints.iter().enumerate() {
            v[slot] = k;
            w[slot] = (weight - next) / total;
        }
        Some((v, w))
    }

    /// The vertices within `radius` of `point`, with their distances.
    fn within(&self, point: Vec3, radius: f32) -> Vec<(f32, u32)> {
        let reach = (radius / CELL).ceil() as i32;
        let c = self.grid.cell(point);
        let mut out = Vec::new();
        for dx in -reach..=reach {
            for dy in -reach..=reach {
                for dz in -reach..=reach {
                    let list = self.grid.cell_members([c[0] + dx, c[1] + dy, c[2] + dz]);
                    for &k in list {
                        let d = self.vertices[k as usize].distance(point);
                        if d <= radius {
                            out.push((d, k));
                        }
                    }
                }
            }
        }
        out
    }

    /// Whether `point` lies between an arm and the torso below the shoulder: nearest to an arm's
    /// vertex, below that arm's shoulder, and closer to the torso's midline (across, in the
    /// torso's frame) than the arm's bones at its height.
    fn under_arm(&self, point: Vec3, near: &[(f32, u32)]) -> bool {
        let Some(&(_, k)) = near.iter().min_by(|a, b| a.0.total_cmp(&b.0)) else {
            return false;
        };
        if !self.arm[k as usize] {
            return false;
        }
        let p = self.torso_from_world.transform_point3(point);
        let vertex = self
            .torso_from_world
            .transform_point3(self.vertices[k as usize]);
        let near_arm = |a: &&[Vec3; 3]| {
            a.iter()
                .map(|j| j.distance(vertex))
                .fold(f32::MAX, f32::min)
        };
        let Some([shoulder, elbow, wrist]) = self
            .arms
            .iter()
            .min_by(|a, b| near_arm(a).total_cmp(&near_arm(b)))
        else {
            return false;
        };
        if p.y >= shoulder.y - BELOW_SHOULDER {
            return false;
        }
        // The bones' x at the point's height: along the upper arm, then the forearm.
        let across = |a: Vec3, b: Vec3| {
            let t = ((p.y - a.y) / (b.y - a.y)).clamp(0.0, 1.0);
            (b.y != a.y).then_some(a.x + t * (b.x - a.x))
        };
        let bone_x = if p.y >= elbow.y {
            across(*shoulder, *elbow)
        } else {
            across(*elbow, *wrist)
        };
        bone_x.is_some_and(|x| p.x.abs() < x.abs())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::BodyPose;

    /// On the default body with its left arm lowered along its side (as a photo's hanging arm):
    /// cloth between the arm and the torso below the shoulder is skinned by the torso alone;
    /// cloth outside the arm by the arm; hair above the head by the head; and every weight set
    /// sums to 1.
    #[test]
    fn cloth_under_the_arm_follows_the_torso_and_a_sleeve_its_arm() {
        let body = BodyModel::default_body().expect("body");
        let mut pose = BodyPose::rest(&body);
        // The A-pose's arm turned down 35° about the body's front axis, to hang near the side.
        pose.set_rotation(&body, "upperarm01.L", Vec3::new(0.0, 0.0, -0.6))
            .expect("joint");
        let mut posed = PosedBody::default();
        body.pose(&pose, &mut posed).expect("pose");
        let anchors = Anchors::new(&body, &posed.vertices, &posed);
        let joint = |n: &str| Vec3::from(posed.joints[body.joint_index(n).expect(n)].translation);
        let (shoulder, elbow) = (joint("upperarm01.L"), joint("lowerarm01.L"));
        let along = |t: f32| shoulder + t * (elbow - shoulder);
        let arm_share = |p: Vec3| {
            let (v, w) = anchors.near(p).expect("anchored");
            assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5, "{w:?}");
            v.iter()
                .zip(w)
                .filter(|(k, _)| anchors.arm[**k as usize])
                .map(|(_, w)| w)
                .sum::<f32>()
        };
        // Between the upper arm (two thirds down) and the torso: 3 cm in from the arm's axis.
        let inside = along(0.66) - Vec3::new(0.03, 0.0, 0.0);
        let outside = along(0.66) + Vec3::new(0.06, 0.0, 0.0);
        println!(
            "arm share: inside {}, outside {}",
            arm_share(inside),
            arm_share(outside)
        );
        assert_eq!(arm_share(inside), 0.0, "under the arm: the torso's");
        assert!(arm_share(outside) > 0.99, "outside the arm: the arm's");
        let top = joint("head") + Vec3::new(0.0, 0.25, 0.0);
        let (v, _) = anchors.near(top).expect("anchored");
        assert!(
            v.iter().all(|&k| anchors.head[k as usize]),
            "hair: the head's"
        );
    }

    /// Hair's skinning is continuous across the hair: walking down columns beside the jaw and
    /// the neck (where the clip's hair lies) in steps of 0.1 mm, each point skinned as hair is
    /// and moved by a pose that turns the spine, the neck and the head, a step grows to at most
    /// 10× (stretching is smooth; a tear is a jump of millimetres). Measured 4.5×; before, with
    /// each joint carried by the vertex nearest the point and the heaviest four joints cut off,
    /// 67× (6.7 mm between points 0.1 mm apart): the clip's hair showed black cracks across it
    /// with her head turned.
    #[test]
    fn hair_skinning_moves_neighbours_together() {
        let body = BodyModel::default_body().expect("body");
        let rest = BodyPose::rest(&body);
        let mut at_rest = PosedBody::default();
        body.pose(&rest, &mut at_rest).expect("pose");
        let anchors = Anchors::new(&body, &at_rest.vertices, &at_rest);
        let mut turned = rest.clone();
        for (joint, angles) in [
            ("spine01", Vec3::new(0.05, 0.15, 0.05)),
            ("neck01", Vec3::new(0.15, 0.25, 0.1)),
            ("neck02", Vec3::new(0.1, 0.2, 0.0)),
            ("head", Vec3::new(0.2, 0.35, -0.1)),
        ] {
            turned.set_rotation(&body, joint, angles).expect(joint);
        }
        let mut posed = PosedBody::default();
        body.pose(&turned, &mut posed).expect("pose");
        let moved = |point: Vec3| {
            let lag = hair_lag(anchors.to_head(point).expect("near the head"));
            let (v, w) = anchors
                .by_joints(&anchors.hair_joints(point, lag))
                .expect("skinned");
            let (anchor, skin) = blend(&v, &w, &at_rest.vertices, &at_rest);
            let offset = skin.inverse() * (point - anchor);
            let (anchor, skin) = blend(&v, &w, &posed.vertices, &posed);
            anchor + skin * offset
        };
        let joint = |n: &str| Vec3::from(at_rest.joints[body.joint_index(n).expect(n)].translation);
        let (head, shoulder) = (joint("head"), joint("clavicle.L"));
        const STEP: f32 = 1e-4;
        let mut worst = 0.0f32;
        for x in [-0.09, -0.07, 0.07, 0.09] {
            let at = |y: f32| moved(Vec3::new(head.x + x, y, head.z));
            let mut y = head.y;
            while y > shoulder.y {
                worst = worst.max(at(y - STEP).distance(at(y)) / STEP);
                y -= STEP;
            }
        }
        println!("a step of 0.1 mm grew to at most {worst:.1}×");
        assert!(worst < 10.0, "hair tears: a step grew {worst:.1}×");
    }
}
