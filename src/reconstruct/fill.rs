//! Filling the texels the source camera did not see (default mode): first from the mirrored
//! texel where the body's left–right symmetry says where that is (a face turned away still shows
//! its other cheek), then, on the back, from what the front shows in front of it
//! ([`super::behind`]), then push–pull inpainting (a weighted image pyramid: coarser levels fill
//! the holes of finer ones, so colours spread smoothly from what was seen).

use glam::Vec3;

use super::texture::UvTexture;
use super::uv_map::UvMap;
use crate::photo::bilinear_clamped;

/// Where a texel's colour came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FillSource {
    Observed,
    Mirrored,
    /// The back, from the front in front of it.
    Behind,
    /// A part of a hand or the teeth the photo does not show, from what it shows of it or the
    /// face's skin ([`super::unseen_parts`]).
    UnseenPart,
    /// The body below the photo's bottom edge, from what the edge shows ([`super::past_edge`]).
    PastEdge,
    Inpainted,
}

/// Mirrored colours count for less than observed ones in the pyramid.
const MIRROR_WEIGHT: f32 = 0.5;
/// Guessed colours (the back's from the front, an unseen hand's skin) count for less again.
const GUESS_WEIGHT: f32 = 0.25;

#[derive(Clone, Debug, PartialEq)]
pub struct FilledTexture {
    pub size: u32,
    /// Every texel has a colour (outside the islands: the pyramid's).
    pub rgb: Vec<[f32; 3]>,
    pub source: Vec<FillSource>,
    /// The source's confidence where observed, half the mirror's where mirrored, 0 where inpainted.
    pub confidence: Vec<f32>,
}

/// Fills `texture` over the valid texels of `uv`, with `guesses` (a colour and what it came
/// from: [`FillSource::Behind`], [`FillSource::UnseenPart`] or [`FillSource::PastEdge`]) where neither
/// the texel nor its mirror image was seen. Returns `None` if no texel was observed.
pub fn fill(
    uv: &UvMap,
    texture: &UvTexture,
    guesses: &[Option<(FillSource, [f32; 3])>],
) -> Option<FilledTexture> {
    let n = (uv.size * uv.size) as usize;
    let mut rgb = texture.rgb.clone();
    let mut weight = texture.confidence.clone();
    let mut source = vec![FillSource::Inpainted; n];
    for &t in &uv.texels {
        let i = t as usize;
        if texture.confidence[i] > 0.0 {
            source[i] = FillSource::Observed;
            continue;
        }
        let m = uv.mirror[i];
        if m >= 0 && texture.confidence[m as usize] > 0.0 {
            rgb[i] = texture.rgb[m as usize];
            weight[i] = MIRROR_WEIGHT * texture.confidence[m as usize];
            source[i] = FillSource::Mirrored;
        } else if let Some(Some((from, colour))) = guesses.get(i) {
            rgb[i] = *colour;
            weight[i] = GUESS_WEIGHT;
            source[i] = *from;
        }
    }
    if weight.iter().all(|&w| w <= 0.0) {
        return None;
    }
    // Every texel, valid or not, gets a colour, so bilinear lookups near island borders see no
    // black from the empty space around the islands.
    let filled = push_pull(uv.size as usize, &rgb, &weight);
    for (i, c) in rgb.iter_mut().enumerate() {
        if source[i] == FillSource::Inpainted {
            *c = filled[i];
            weight[i] = 0.0;
        }
    }
    Some(FilledTexture {
        size: uv.size,
        rgb,
        source,
        confidence: weight,
    })
}

/// Colours for every texel of a `size`² grid from the known ones (`weight > 0`).
fn push_pull(size: usize, rgb: &[[f32; 3]], weight: &[f32]) -> Vec<[f32; 3]> {
    // Push: weighted sums, halving the side until one texel is left.
    let mut levels = vec![(
        size,
        rgb.iter()
            .zip(weight)
            .map(|(c, &w)| Vec3::from(*c) * w)
            .collect::<Vec<_>>(),
        weight.to_vec(),
    )];
    while levels.last().is_some_and(|l| l.0 > 1) {
        let (s, sum, w) = levels.last().expect("non-empty");
        let half = s.div_ceil(2);
        let mut sum2 = vec![Vec3::ZERO; half * half];
        let mut w2 = vec![0.0; half * half];
        for r in 0..*s {
            for c in 0..*s {
                let (i, j) = (r * s + c, (r / 2) * half + c / 2);
                sum2[j] += sum[i];
                w2[j] += w[i];
            }
        }
        levels.push((half, sum2, w2));
    }
    // Pull: from the top, each level's unknown texels take the coarser level's colour.
    let mut coarse: Option<(usize, Vec<Vec3>)> = None;
    for (s, sum, w) in levels.into_iter().rev() {
        let colour: Vec<Vec3> = (0..s * s)
            .map(|i| {
                if w[i] > 0.0 {
                    sum[i] / w[i]
                } else if let Some((cs, cc)) = &coarse {
                    let (r, c) = (i / s, i % s);
                    bilinear_clamped(
                        *cs,
                        (c as f32 + 0.5) / 2.0 - 0.5,
                        (r as f32 + 0.5) / 2.0 - 0.5,
                        |k| cc[k],
                    )
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        coarse = Some((s, colour));
    }
    coarse
        .map(|(_, c)| c.iter().map(Vec3::to_array).collect())
        .unwrap_or_default()
}
