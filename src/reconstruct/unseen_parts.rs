//! Colours for the parts of the hands and the teeth the photo does not show (default mode).
//! An upper-body photo often cuts the hands off at its bottom edge, or a held object or the
//! other arm hides them, and a closed mouth hides the teeth; left to the inpainting, such a part
//! took the colours nearest it in the UV layout (a sleeve's blue patches on a synthetic subject's
//! hands, white blobs on a waving avatar, a grey slab of the torso's colours in a laughing mouth).
//! A part the photo shows little of (its texels and their mirror images) takes the median of
//! what it shows, and one it shows nothing of a guess from the face's skin: the person's own skin
//! for a hand, and for teeth that skin with most of its tint taken out and brightened (teeth are
//! near-white under the same light). A part it shows well is left to the inpainting, which
//! spreads its own colours (a glove stays a glove).

use glam::Vec3;

use super::behind::median;
use super::texture::UvTexture;
use super::uv_map::UvMap;
use crate::body::BodyModel;

/// A part's colour guessed from the face's skin, where the photo shows none of the part.
type Guess = fn(&Skin) -> [f32; 3];
/// The parts guessed, each with its guess.
const PARTS: [(&str, Guess); 3] = [
    ("hand.L", Skin::hand),
    ("hand.R", Skin::hand),
    ("teeth", Skin::teeth),
];
/// A part whose texels are seen (directly or through its mirror) less than this share of them
/// has the rest of its colour guessed; above it, the inpainting spreads its own colours.
const SEEN_SHARE: f32 = 0.1;
/// The face: head points this far in front of the head joint (metres, rest pose) and below
/// this height above it (the forehead below the hairline; higher is the scalp, which may wear
/// hair). The same bounds hold the clothing layer off the face.
const FACE_FRONT: f32 = 0.02;
pub const FACE_BELOW: f32 = 0.06;
/// Teeth from the face's skin: the share of the skin's tint kept (the rest of a tint is the
/// skin's own; what is kept stands for the light's), the brightness relative to the lit skin's,
/// and its bounds. Natural teeth (VITA A1–A3, L* ≈ 75) are about ten L* brighter than light skin
/// (L* ≈ 65), 1.15× in 8-bit sRGB values at these levels; the bounds keep a dark skin's teeth from
/// going grey and an overexposed face's from white.
const TOOTH_TINT: f32 = 0.35;
const TOOTH_BRIGHTNESS: f32 = 1.15;
const TOOTH_RANGE: (f32, f32) = (0.6, 0.9);
/// The lit skin: this quantile of the face's seen texels' brightness (the median is darkened by
/// shading, brows and lashes; teeth are measured against skin in the light).
const LIT_QUANTILE: f32 = 0.9;

/// The face's skin as the photo shows it.
struct Skin {
    /// The median colour of the face's seen texels.
    colour: [f32; 3],
    /// The [`LIT_QUANTILE`] of their brightness (mean of RGB).
    lit: f32,
}

fn brightness(c: [f32; 3]) -> f32 {
    c.iter().sum::<f32>() / 3.0
}

impl Skin {
    /// The face's skin from its seen texels' colours; `None` when there are none.
    fn of(colours: Vec<[f32; 3]>) -> Option<Self> {
        let mut levels: Vec<f32> = colours.iter().map(|&c| brightness(c)).collect();
        let colour = median(colours)?;
        let k = ((levels.len() - 1) as f32 * LIT_QUANTILE) as usize;
        let (_, &mut lit, _) = levels.select_nth_unstable_by(k, f32::total_cmp);
        Some(Self { colour, lit })
    }

    /// A hand the photo shows nothing of: the skin itself.
    fn hand(&self) -> [f32; 3] {
        self.colour
    }

    /// Teeth the photo shows nothing of (see [`TOOTH_TINT`]).
    fn teeth(&self) -> [f32; 3] {
        let level = brightness(self.colour);
        let tooth = (TOOTH_BRIGHTNESS * self.lit).clamp(TOOTH_RANGE.0, TOOTH_RANGE.1);
        match level > 0.0 {
            true => self
                .colour
                .map(|c| tooth * (1.0 + TOOTH_TINT * (c / level - 1.0))),
            false => [tooth; 3],
        }
    }
}

/// Whether a head point at `p` (rest pose) is the face, the head joint resting at `head`.
pub fn on_face(head: Vec3, p: Vec3) -> bool {
    p.z - head.z > FACE_FRONT && p.y - head.y < FACE_BELOW
}

/// Per texel of `uv`: for the unseen texels (neither they nor their mirror images seen) of a part
/// of [`PARTS`] the photo shows less than [`SEEN_SHARE`] of, the median of what it shows of that
/// part, or its guess from the face's skin where it shows none; `None` elsewhere, and everywhere
/// when the photo shows no face.
pub fn unseen_parts(body: &BodyModel, uv: &UvMap, texture: &UvTexture) -> Vec<Option<[f32; 3]>> {
    let n = (uv.size * uv.size) as usize;
    let mut out = vec![None; n];
    let seen = |i: usize| texture.confidence[i] > 0.0;
    let part = |i: usize| body.part_of(uv.nearest_vertex(i, &body.triangles));
    let head = body.joint_index("head").map(|j| body.joints[j].rest);
    let skin = Skin::of(
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
    for (name, guess) in PARTS {
        let texels: Vec<usize> = uv
            .texels
            .iter()
            .map(|&t| t as usize)
            .filter(|&i| part(i) == Some(name))
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
        let colour = own.unwrap_or_else(|| guess(&skin));
        for i in texels {
            if !seen(i) && !mirrored(i) {
                out[i] = Some(colour);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The body seen from the front down to its chest, the mouth closed: the face in skin,
    /// everything else in navy. The hands, neither seen nor mirrored, take the face's skin (the
    /// inpainting brought the sleeves' navy there) and the teeth a tooth's colour from it; a hand
    /// a fifth seen, in a glove, keeps its glove.
    #[test]
    fn unseen_hands_and_teeth_take_colours_from_the_faces_skin_and_a_seen_glove_stays_a_glove() {
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
            if p.z > head.z + 0.03 && p.y > head.y - 0.3 && part(i) != Some("teeth") {
                let face = part(i) == Some("head") && p.y < head.y + FACE_BELOW;
                texture.rgb[i] = if face { skin } else { navy };
                texture.confidence[i] = 1.0;
            }
        }
        let guessed = unseen_parts(&body, &uv, &texture);
        for &i in &texels {
            let expected = match part(i) {
                Some("hand.L" | "hand.R") => Some(skin),
                Some("teeth") => Some(
                    Skin {
                        colour: skin,
                        lit: brightness(skin),
                    }
                    .teeth(),
                ),
                _ => None,
            };
            assert_eq!(guessed[i], expected, "texel {i}: {:?}", part(i));
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
        let guessed = unseen_parts(&body, &uv, &texture);
        for &i in &texels {
            if matches!(part(i), Some("hand.L" | "hand.R")) {
                assert_ne!(guessed[i], Some(skin), "texel {i}");
            }
        }
    }

    /// Teeth guessed from skin are near-white whatever the skin: brighter than the lit skin,
    /// with little of its tint, and not grey for a dark one.
    #[test]
    fn teeth_from_skin_are_a_bright_near_neutral() {
        let tint = |c: [f32; 3]| {
            c.iter()
                .fold(0.0f32, |m, x| m.max((x / brightness(c) - 1.0).abs()))
        };
        for colour in [[0.80, 0.60, 0.50], [0.70, 0.59, 0.55], [0.35, 0.22, 0.16]] {
            let lit = brightness(colour) + 0.05;
            let tooth = Skin { colour, lit }.teeth();
            let level = brightness(tooth);
            assert!(
                level > lit && (0.599..=0.901).contains(&level),
                "{colour:?} → {tooth:?}"
            );
            assert!(tint(tooth) < 0.4 * tint(colour), "{colour:?} → {tooth:?}");
        }
    }
}
