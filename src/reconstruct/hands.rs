//! Colours for the parts of a hand the photo does not show (default mode). An upper-body photo
//! often cuts the hands off at its bottom edge, or a held object or the other arm hides them;
//! left to the inpainting, a hand took the colours nearest it in the UV layout (a sleeve's blue
//! patches on a synthetic subject's hands, white blobs on a waving avatar). A hand the photo
//! shows little of (its texels and their mirror images) takes the median of what it shows, and
//! one it shows nothing of the face's skin: the person's own skin is the best guess one photo
//! gives for a hand. A hand it shows well is left to the inpainting, which spreads its own
//! colours (a glove stays a glove).

use glam::Vec3;

use super::behind::median;
use super::texture::UvTexture;
use super::uv_map::UvMap;
use crate::body::BodyModel;

/// The body's parts that are hands.
const HANDS: [&str; 2] = ["hand.L", "hand.R"];
/// A hand whose texels are seen (directly or through its mirror) less than this share of them
/// has the rest of its colour guessed; above it, the inpainting spreads its own colours.
const SEEN_SHARE: f32 = 0.1;
/// The face: head points this far in front of the head joint (metres, rest pose) and below
/// this height above it (the forehead below the hairline; higher is the scalp, which may wear
/// hair). The same bounds hold the clothing layer off the face.
const FACE_FRONT: f32 = 0.02;
pub const FACE_BELOW: f32 = 0.06;

/// Whether a head point at `p` (rest pose) is the face, the head joint resting at `head`.
pub fn on_face(head: Vec3, p: Vec3) -> bool {
    p.z - head.z > FACE_FRONT && p.y - head.y < FACE_BELOW
}

/// Per texel of `uv`: for the unseen texels (neither they nor their mirror images seen) of a hand
/// the photo shows less than [`SEEN_SHARE`] of, the median of what it shows of that hand, or the
/// face's skin where it shows none; `None` elsewhere, and everywhere when the photo shows no face.
pub fn unseen_hands(body: &BodyModel, uv: &UvMap, texture: &UvTexture) -> Vec<Option<[f32; 3]>> {
    let n = (uv.size * uv.size) as usize;
    let mut out = vec![None; n];
    let seen = |i: usize| texture.confidence[i] > 0.0;
    let part = |i: usize| body.part_of(uv.nearest_vertex(i, &body.triangles));
    let head = body.joint_index("head").map(|j| body.joints[j].rest);
    let skin = median(
        uv.texels
            .iter()
            .map(|&t| t as usize)
            .filter(|&i| seen(i) && part(i) == Some("head"))
            .filter(|&i| {
                let p = uv.point(i, &body.vertices, &body.triangles);
                head.is_some_and(|h| on_face(h, p))
            })
            .map(|i| texture.rgb[i])
            .collect(),
    );
    let Some(skin) = skin else { return out };
    for hand in HANDS {
        let texels: Vec<usize> = uv
            .texels
            .iter()
            .map(|&t| t as usize)
            .filter(|&i| part(i) == Some(hand))
            .collect();
        let mirrored = |i: usize| uv.mirror[i] >= 0 && seen(uv.mirror[i] as usize);
        let shown = texels.iter().filter(|&&i| seen(i) || mirrored(i)).count();
        if (shown as f32) >= SEEN_SHARE * texels.len() as f32 {
            continue;
        }
        let own = median(
            texels
                .iter()
                .filter(|&&i| seen(i) || mirrored(i))
                .map(|&i| match seen(i) {
                    true => texture.rgb[i],
                    false => texture.rgb[uv.mirror[i] as usize],
                })
                .collect(),
        );
        for i in texels {
            if !seen(i) && !mirrored(i) {
                out[i] = Some(own.unwrap_or(skin));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The body seen from the front down to its chest: the face in skin, everything else in
    /// navy. The hands, neither seen nor mirrored, take the face's skin (the inpainting brought
    /// the sleeves' navy there); a hand a fifth seen, in a glove, keeps its glove.
    #[test]
    fn an_unseen_hand_takes_the_faces_skin_and_a_seen_glove_stays_a_glove() {
        let body = BodyModel::default_body().expect("body");
        let uv = UvMap::for_body(&body, 128);
        let (navy, skin, glove) = ([0.1, 0.1, 0.3], [0.8, 0.6, 0.5], [0.2, 0.2, 0.2]);
        let n = (uv.size * uv.size) as usize;
        let mut texture = UvTexture {
            size: uv.size,
            rgb: vec![[0.0; 3]; n],
            confidence: vec![0.0; n],
        };
        let head = body.joints[body.joint_index("head").expect("head")].rest;
        let part = |i: usize| body.part_of(uv.nearest_vertex(i, &body.triangles));
        let texels: Vec<usize> = uv.texels.iter().map(|&t| t as usize).collect();
        for &i in &texels {
            let p = uv.point(i, &body.vertices, &body.triangles);
            if p.z > head.z + 0.03 && p.y > head.y - 0.3 {
                let face = part(i) == Some("head") && p.y < head.y + FACE_BELOW;
                texture.rgb[i] = if face { skin } else { navy };
                texture.confidence[i] = 1.0;
            }
        }
        let guessed = unseen_hands(&body, &uv, &texture);
        for &i in &texels {
            let hand = matches!(part(i), Some("hand.L" | "hand.R"));
            assert_eq!(guessed[i], hand.then_some(skin), "texel {i}: {:?}", part(i));
        }
        // A fifth of the left hand seen in a glove: its mirror, the right hand, shows the glove
        // too, and neither takes skin.
        let left: Vec<usize> = texels
            .iter()
            .copied()
            .filter(|&i| part(i) == Some("hand.L"))
            .collect();
        for &i in left.iter().step_by(5) {
            texture.rgb[i] = glove;
            texture.confidence[i] = 1.0;
        }
        let guessed = unseen_hands(&body, &uv, &texture);
        for &i in &texels {
            if matches!(part(i), Some("hand.L" | "hand.R")) {
                assert_ne!(guessed[i], Some(skin), "texel {i}");
            }
        }
    }
}
