//! Hair's volume behind the head (default mode). The front photo shows how far hair stands off
//! the head only around its outline; behind the head it shows nothing, and seen from the side
//! the avatar had a shaved skull behind a sheet of hair discs. Hair stands about as far off the
//! back of the head as off its top and sides, so a shell of discs in the crown's colour (the
//! back of the head's) is laid behind the skull: as far off it as the hair seen around the
//! head's outline where it faces straight away from the camera, tapering to the skull towards
//! the outline, each disc riding its head vertex. Only discs the body hides from the photo's
//! camera are kept: the photo shows the hair around the outline itself (the discs beyond the
//! body), and shell discs peeking past the outline or in front of the neck changed the source
//! view. A bald head or a tight cap shows no hair around it and gets no shell. (Dressing the
//! skull out by the same amount instead tore it at the ears: docs/reconstruction.md.)

use glam::{Vec2, Vec3};

use super::extras::{Extra, PERSON, facing, push};
use super::unseen_parts::FACE_BELOW;
use crate::avatar::SkinnedGaussians;
use crate::body::{BodyModel, PosedBody};
use crate::camera::Camera;
use crate::photo::Shown;
use crate::raster::Fragments;

/// The most hair is taken to stand off the skull (metres); more around the head is a raised
/// hand or a hat, not hair lying on the back of the head.
pub const MAX_HAIR: f32 = 0.05;
/// Where the skull faces away from the camera this much (cosine of its direction from the
/// head's middle with the view), the shell stands the whole thickness off it; less, a share.
const FULL_FACING: f32 = 0.5;
/// Columns either side of each outermost head point whose runs of hair give the median.
const COLUMNS: i32 = 4;
/// A shell disc's standard deviation across, in its vertex's longest edges, and along its
/// normal (metres).
const ACROSS: f32 = 0.6;
const ALONG: f32 = 0.002;
const OPACITY: f32 = 0.95;
/// How far behind the body's surface (metres along the view) a disc must be to count as hidden.
const BEHIND: f32 = 0.01;
/// The skull: head vertices (rest) above this height below the head joint; lower are the jaw,
/// the chin and the neck, which hair does not stand off.
pub(super) const SKULL_BELOW: f32 = 0.02;

/// How far hair stands off the head of `posed` seen by `camera` on `mask` (`camera.width`²,
/// row-major; the photo where it is `shown`), in metres, at most [`MAX_HAIR`]: the median run of
/// person pixels past the head's outline above the crown and beside the head above the hairline,
/// over a few columns each, where the photo shows them whole (a run cut by the photo's edge, or
/// by a padded square's padding, says nothing); 0 without any.
pub fn thickness(
    body: &BodyModel,
    posed: &PosedBody,
    camera: &Camera,
    mask: &[f32],
    shown: Shown,
) -> f32 {
    let Some(j) = body.joint_index("head") else {
        return 0.0;
    };
    let head: Vec3 = posed.joints[j].translation.into();
    let centre = camera.project(head);
    // The image direction of "up" at the head, and across it.
    let up = (camera.project(head + Vec3::Y * 0.01) - centre).truncate();
    if !(centre.z > 0.0 && up.length() > 1e-6) {
        return 0.0;
    }
    let up = up.normalize();
    let across = Vec2::new(-up.y, up.x);
    let footprint = camera.pixel_footprint(centre.z);
    let most = (MAX_HAIR / footprint).ceil() as i32;
    let size = camera.width as i32;
    let person = |p: Vec2| {
        let p = p.floor().as_ivec2();
        shown
            .contains(p.x.into(), p.y.into())
            .then(|| mask[(p.y * size + p.x) as usize] >= PERSON)
    };
    // Person pixels from `start` along `dir`, up to the most hair; `None` where the photo's edge
    // cuts the run or `start` is off the photo.
    let run = |start: Vec2, dir: Vec2| -> Option<i32> {
        person(start)?;
        for k in 1..=most {
            match person(start + dir * k as f32) {
                Some(true) => {}
                Some(false) => return Some(k - 1),
                None => return None,
            }
        }
        Some(most)
    };
    let hairline = head.y + FACE_BELOW;
    let from = centre.truncate();
    let outermost = |dir: Vec2| {
        head_vertices(body)
            .map(|v| posed.vertices[v])
            .filter(|p| dir == up || p.y > hairline)
            .map(|p| camera.project(p).truncate())
            .max_by(|a, b| (*a - from).dot(dir).total_cmp(&(*b - from).dot(dir)))
    };
    let mut runs = Vec::new();
    for dir in [up, across, -across] {
        let Some(edge) = outermost(dir) else { continue };
        let side = Vec2::new(-dir.y, dir.x);
        runs.extend((-COLUMNS..=COLUMNS).filter_map(|c| run(edge + side * c as f32, dir)));
    }
    if runs.is_empty() {
        return 0.0;
    }
    runs.sort_unstable();
    (runs[runs.len() / 2] as f32 * footprint).min(MAX_HAIR)
}

/// Appends to `out` the shell of `colour` discs `hair` metres behind the head of the posed,
/// dressed body `posed` seen by `camera`, each skinned by its head vertex, on the
/// skull's far half above the ears only, and only where the body hides the disc from the photo's
/// camera (`fragments`: the body's rasterization from it), so the photo's view keeps what the
/// photo shows. Returns how many.
pub fn shell(
    out: &mut SkinnedGaussians,
    body: &BodyModel,
    posed: &PosedBody,
    camera: &Camera,
    fragments: &Fragments,
    hair: f32,
    colour: [f32; 3],
) -> usize {
    // One vertex of each welded group (a UV seam splits one position into several).
    let mut taken = vec![false; body.weld.iter().max().map_or(0, |&m| m as usize + 1)];
    let skull = body
        .joint_index("head")
        .map_or(f32::MAX, |j| body.joints[j].rest.y - SKULL_BELOW);
    let head: Vec<usize> = head_vertices(body)
        .filter(|&v| body.vertices[v].y > skull)
        .filter(|&v| !std::mem::replace(&mut taken[body.weld[v] as usize], true))
        .collect();
    if hair <= 0.0 || head.is_empty() {
        return 0;
    }
    let vertices = &posed.vertices;
    let middle = head.iter().map(|&v| vertices[v]).sum::<Vec3>() / head.len() as f32;
    // Each vertex's spacing: its longest edge (the skull's back is meshed far coarser than the
    // face; one spacing for all left gaps between the discs there).
    let mut spacing = vec![0.0f32; vertices.len()];
    for t in &body.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let d = vertices[a].distance(vertices[b]);
            spacing[a] = spacing[a].max(d);
            spacing[b] = spacing[b].max(d);
        }
    }
    let eye = camera
        .view_from_world
        .inverse()
        .transform_point3(Vec3::ZERO);
    let view = (middle - eye).normalize_or_zero();
    let added = out.len();
    for v in head {
        let radial = (vertices[v] - middle).normalize_or_zero();
        let share = (radial.dot(view) / FULL_FACING).clamp(0.0, 1.0);
        if share <= 0.0 {
            continue;
        }
        let point = vertices[v] + radial * share * hair;
        let radius = vertices[v].distance(middle);
        let across = ACROSS * spacing[v] * (radius + share * hair) / radius.max(1e-3);
        // Hidden from the photo's camera behind the body.
        let hidden = hidden(camera, point, across, |i| {
            (fragments.triangle[i] >= 0).then_some(fragments.depth[i])
        });
        if !hidden {
            continue;
        }
        let extra = Extra {
            scale: [across, ALONG, across],
            opacity: OPACITY,
            features: [colour[0], colour[1], colour[2], 0.0],
        };
        push(
            out,
            point,
            ([v as u32; 4], [1.0, 0.0, 0.0, 0.0]),
            // Facing out from the head.
            facing(radial),
            &extra,
            vertices,
            posed,
        );
    }
    out.len() - added
}

/// Whether a disc at `point`, `across` wide, is hidden from `camera`: at its centre and two
/// deviations either way across and down, `front` (per pixel, the depth of what the photo shows
/// there; `None` for nothing) lies [`BEHIND`] or more in front of it.
pub(super) fn hidden(
    camera: &Camera,
    point: Vec3,
    across: f32,
    front: impl Fn(usize) -> Option<f32>,
) -> bool {
    let at = camera.project(point);
    let reach = 2.0 * across / camera.pixel_footprint(at.z);
    let size = camera.width as i32;
    [(0.0, 0.0), (1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)]
        .iter()
        .all(|&(dx, dy)| {
            let p = (at.truncate() + Vec2::new(dx, dy) * reach)
                .floor()
                .as_ivec2();
            let inside = p.x >= 0 && p.y >= 0 && p.x < size && p.y < size;
            inside && front((p.y * size + p.x) as usize).is_some_and(|z| z + BEHIND < at.z)
        })
}

fn head_vertices(body: &BodyModel) -> impl Iterator<Item = usize> + '_ {
    (0..body.vertices.len()).filter(|&v| body.part_of(v) == Some("head"))
}
