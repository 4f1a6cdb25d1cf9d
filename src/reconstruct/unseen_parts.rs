//! Colours for the parts of the hands, the teeth and the eyes the photo does not show (default
//! mode).
//! An upper-body photo often cuts the hands off at its bottom edge, or a held object or the
//! other arm hides them, and a closed mouth hides the teeth; left to the inpainting, such a part
//! took the colours nearest it in the UV layout (a sleeve's blue patches on a synthetic subject's
//! hands, white blobs on a waving avatar, a grey slab of the torso's colours in a laughing mouth).
//! A part the photo shows little of (its texels and their mirror images) takes the median of
//! what it shows, and one it shows nothing of a guess from the face's skin: the person's own skin
//! for a hand, and for teeth that skin with most of its tint taken out and brightened (teeth are
//! near-white under the same light). A part it shows well is left to the inpainting, which
//! spreads its own colours (a glove stays a glove). What the photo does not show of an eyeball
//! is an eye looking straight ahead, whatever it shows of the rest: the sclera as teeth are,
//! the iris and the pupil darker skin.

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

/// Each eyeball's front and back parts. What the photo does not show of an eyeball (all of it
/// behind shut lids, its top and bottom behind open ones) is guessed as an eye: left to the
/// inpainting, an avatar opening its eyes wider than the photo did showed a blank ball of the
/// lids' skin.
const EYES: [(&str, &str); 2] = [("eye_front.L", "eye_back.L"), ("eye_front.R", "eye_back.R")];
/// An eye looking straight ahead: the iris within this cosine of the eyeball's forward axis (a
/// 12 mm iris on the default body's eyeball, 15 mm in radius: 24°), the pupil within the second
/// (a 4 mm pupil: 8°).
const IRIS_COSINE: f32 = 0.915;
const PUPIL_COSINE: f32 = 0.99;
/// The iris and pupil from the face's skin (its light kept): an iris as dark against skin as a
/// brown one (the commonest), a pupil near black.
const IRIS_SHADE: f32 = 0.4;
const PUPIL_SHADE: f32 = 0.1;

/// An eye the photo does not show, guessed looking straight ahead: the sclera as teeth are
/// ([`Skin::teeth`]), the iris and pupil darker skin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyeGuess {
    /// The eyeball's front part.
    pub part: &'static str,
    /// The eyeball's centre at rest (the mean of its front and back parts' vertices); its
    /// forward axis is +z.
    centre: Vec3,
    sclera: [f32; 3],
    iris: [f32; 3],
    pupil: [f32; 3],
}

impl EyeGuess {
    /// The colour at `p` on the eyeball (rest pose).
    pub fn at(&self, p: Vec3) -> [f32; 3] {
        match (p - self.centre).normalize_or_zero().z {
            a if a >= PUPIL_COSINE => self.pupil,
            a if a >= IRIS_COSINE => self.iris,
            _ => self.sclera,
        }
    }
}

/// Each eye of `body` as guessed from the face's `skin`, for what the photo does not show of it.
fn guessed_eyes(body: &BodyModel, skin: &Skin) -> Vec<EyeGuess> {
    let shade = |k: f32| skin.colour.map(|c| k * c);
    EYES.iter()
        .filter_map(|&(front, back)| {
            let ball: Vec<Vec3> = (0..body.vertices.len())
                .filter(|&v| body.part_of(v).is_some_and(|p| p == front || p == back))
                .map(|v| body.vertices[v])
                .collect();
            (!ball.is_empty()).then(|| EyeGuess {
                part: front,
                centre: ball.iter().sum::<Vec3>() / ball.len() as f32,
                sclera: skin.teeth(),
                iris: shade(IRIS_SHADE),
                pupil: shade(PUPIL_SHADE),
            })
        })
        .collect()
}

/// Whether a head point at `p` (rest pose) is the face, the head joint resting at `head`.
pub fn on_face(head: Vec3, p: Vec3) -> bool {
    p.z - head.z > FACE_FRONT && p.y - head.y < FACE_BELOW
}

/// The colours guessed for what the photo does not show of the hands, the teeth and the eyes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UnseenParts {
    /// Per texel: the guess, `None` where there is none.
    pub texels: Vec<Option<[f32; 3]>>,
    /// The eyes guessed, for the eyeballs' fine discs ([`super::eyes`]).
    pub eyes: Vec<EyeGuess>,
}

/// Per texel of `uv`: for the unseen texels (neither they nor their mirror images seen) of a part
/// of [`PARTS`] the photo shows less than [`SEEN_SHARE`] of, the median of what it shows of that
/// part, or its guess from the face's skin where it shows none, and for the eyeballs' fronts an
/// eye looking straight ahead ([`EyeGuess`]); `None` elsewhere, and everywhere when the photo
/// shows no face.
pub fn unseen_parts(body: &BodyModel, uv: &UvMap, texture: &UvTexture) -> UnseenParts {
    let n = (uv.size * uv.size) as usize;
    let mut out = UnseenParts {
        texels: vec![None; n],
        eyes: Vec::new(),
    };
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
    let mirrored = |i: usize| uv.mirror[i] >= 0 && seen(uv.mirror[i] as usize);
    out.eyes = guessed_eyes(body, &skin);
    for i in uv.texels.iter().map(|&t| t as usize) {
        let of = part(i);
        let Some(eye) = out.eyes.iter().find(|e| of == Some(e.part)) else {
            continue;
        };
        if !seen(i) && !mirrored(i) {
            out.texels[i] = Some(eye.at(uv.point(i, &body.vertices, &body.triangles)));
        }
    }
    for (name, guess) in PARTS {
        let texels: Vec<usize> = uv
            .texels
            .iter()
            .map(|&t| t as usize)
            .filter(|&i| part(i) == Some(name))
            .collect();
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
                out.texels[i] = Some(colour);
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
            assert_eq!(guessed.texels[i], expected, "texel {i}: {:?}", part(i));
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
                assert_ne!(guessed.texels[i], Some(skin), "texel {i}");
            }
        }
    }

    /// Eyes are guessed looking straight ahead: each eyeball's centre is its eye joint's place
    /// (within 3 mm), the point straight ahead of it the pupil, 15° off the iris, 45° off the
    /// sclera; the sclera brighter than the lit skin, the iris darker than the skin and the pupil
    /// darker again.
    #[test]
    fn unseen_eyes_are_guessed_looking_straight_ahead() {
        let body = BodyModel::default_body().expect("body");
        let skin = Skin {
            colour: [0.8, 0.6, 0.5],
            lit: 0.7,
        };
        let eyes = guessed_eyes(&body, &skin);
        assert_eq!(eyes.len(), 2);
        for eye in &eyes {
            let joint = if eye.part.ends_with(".L") {
                "eye.L"
            } else {
                "eye.R"
            };
            let joint = body.joints[body.joint_index(joint).expect(joint)].rest;
            assert!(
                eye.centre.distance(joint) < 0.003,
                "{eye:?} against {joint}"
            );
            let at = |degrees: f32| {
                let (sin, cos) = degrees.to_radians().sin_cos();
                eye.at(eye.centre + 0.015 * Vec3::new(sin, 0.0, cos))
            };
            assert_eq!(at(0.0), eye.pupil);
            assert_eq!(at(15.0), eye.iris);
            assert_eq!(at(45.0), eye.sclera);
            let level = |c: [f32; 3]| brightness(c);
            assert!(level(eye.sclera) > skin.lit, "{eye:?}");
            assert!(level(eye.iris) < level(skin.colour), "{eye:?}");
            assert!(level(eye.pupil) < level(eye.iris), "{eye:?}");
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
