//! Colours for the body below the photo's bottom edge (default mode). A portrait or a video
//! frame often cuts the person at the chest; left to the inpainting, the body below the cut took
//! the colours nearest it in the UV layout (the neck's skin among them), so turned views showed a
//! bare torso under a black top. Here each unseen texel whose point the photo's camera places
//! below the bottom edge takes what the photo shows at that edge, straight above it: the median of
//! the person pixels in a window on the edge (a top goes on below the cut). Only the bottom edge:
//! past a side, a window on the edge mixes a sleeve with the hand beside it (the synthetic jacket's
//! forearms took the hand's skin, 0.16 dB lost from the side), and above the top there is only the
//! head. The head and the hands are left out (the back of the head takes the crown's colour,
//! [`super::behind`]; a hand, [`super::hands`]'s), and the pixels where the photo shows them give
//! nothing (a hand resting at the bottom edge is not the shirt below it).

use std::collections::HashMap;

use glam::Vec3;

use super::behind::median;
use super::extras::PERSON;
use super::texture::UvTexture;
use super::uv_map::UvMap;
use crate::body::BodyModel;
use crate::camera::Camera;
use crate::photo::SourceImage;
use crate::raster::Fragments;

/// Half widths and depths (pixels of the 512² source) of the window on the edge, tried in turn
/// until one holds a person pixel: a band about as deep as a collar at a close-up's scale, then
/// wider.
const WINDOW_RADII: [i32; 3] = [8, 16, 32];
/// Windows are shared by the texels below one cell of the edge this many pixels wide.
const CELL: i32 = 4;

/// Per body vertex: whether it is the head's or a hand's, neither given nor giving colour here:
/// the head and hand parts, and what a wrist moves most (the wrist itself, which the hand part
/// leaves to the arm, is skin beside a sleeve's cuff as often as not).
fn head_or_hand(body: &BodyModel) -> Vec<bool> {
    let under_wrist: Vec<bool> = (0..body.joints.len())
        .map(|j| {
            std::iter::successors(Some(j), |&j| body.joints[j].parent)
                .any(|j| body.joints[j].name.starts_with("wrist."))
        })
        .collect();
    (0..body.vertices.len())
        .map(|v| {
            under_wrist[body.dominant_joint(v)]
                || body
                    .part_of(v)
                    .is_none_or(|p| p == "head" || p.starts_with("hand."))
        })
        .collect()
}

/// Per texel of `uv`: for the unseen texels (not the head's, not the hands') whose point on the
/// body posed at `vertices` lies below the bottom edge of `photo` as `camera` sees it, the median
/// colour of the person pixels on that edge above it, leaving out those where `fragments` (the
/// posed body rasterized from `camera`) shows the head or a hand; `None` elsewhere, and where the
/// edge there shows no such person pixel within the widest window.
pub fn past_edge(
    body: &BodyModel,
    uv: &UvMap,
    vertices: &[Vec3],
    camera: &Camera,
    photo: &SourceImage,
    fragments: &Fragments,
    texture: &UvTexture,
) -> Vec<Option<[f32; 3]>> {
    let n = (uv.size * uv.size) as usize;
    let mut out = vec![None; n];
    if photo.mask.is_none() {
        return out;
    }
    let side = photo.size as i32;
    // The photo's own edges in its square (a padded square's padding shows nothing).
    let (left, right, bottom) = (
        photo.shown.left as i32,
        photo.shown.right as i32,
        photo.shown.bottom as i32,
    );
    let excluded = head_or_hand(body);
    let mut edges: HashMap<i32, Option<[f32; 3]>> = HashMap::new();
    for &t in &uv.texels {
        let i = t as usize;
        if texture.confidence[i] > 0.0 {
            continue;
        }
        if excluded[uv.nearest_vertex(i, &body.triangles)] {
            continue;
        }
        let q = camera.project(uv.point(i, vertices, &body.triangles));
        if !q.is_finite() || q.z <= 0.0 || q.y < bottom as f32 || right <= left {
            continue;
        }
        let x = (q.x.floor() as i32).clamp(left, right - 1);
        out[i] = *edges.entry(x / CELL).or_insert_with(|| {
            let centre = x / CELL * CELL + CELL / 2;
            WINDOW_RADII.iter().find_map(|&r| {
                let mut colours = Vec::new();
                for y in (bottom - 1 - r).max(0)..bottom {
                    for x in (centre - r).max(left)..=(centre + r).min(right - 1) {
                        let k = (y * side + x) as usize;
                        let on_head_or_hand = usize::try_from(fragments.triangle[k])
                            .is_ok_and(|t| excluded[body.triangles[t][0] as usize]);
                        if photo.pixel(k).1 >= PERSON && !on_head_or_hand {
                            colours.push(photo.straight(k));
                        }
                    }
                }
                median(colours)
            })
        });
    }
    out
}

/// `photo` with the person at its bottom edge continued straight down through the padding below
/// it (a padded square's), for the Gaussians beyond the body: the hair and clothing a frame cuts
/// go on past the cut, as the body does. Without them, a person rising in a video showed the
/// background where her hair had gone on below the reference frame's edge.
pub fn continued_below(photo: &SourceImage) -> SourceImage {
    let mut out = photo.clone();
    let (size, shown) = (photo.size as i64, photo.shown);
    let Some(mask) = out.mask.as_mut() else {
        return out;
    };
    if shown.bottom <= shown.top || shown.bottom >= size {
        return out;
    }
    for x in shown.left.max(0)..shown.right.min(size) {
        let edge = ((shown.bottom - 1) * size + x) as usize;
        for y in shown.bottom..size {
            let i = (y * size + x) as usize;
            mask[i] = mask[edge];
            out.rgb.copy_within(3 * edge..3 * edge + 3, 3 * i);
        }
    }
    out
}
