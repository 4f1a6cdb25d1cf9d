//! Colours for the body's back, which one photo from the front cannot show (default mode). Left
//! to the texture's inpainting, the back took the colours nearest it in the UV map (the neck's
//! and the arms' skin: a bare back under a jacket) or a print mirrored from the front. Here each
//! unseen texel facing away from the camera takes what is in front of it through the body, in
//! the rest pose seen from the front, after a median over a hand's width (so the cloth's colour
//! comes through and a badge or a print does not); where the front shows nothing there (below
//! the photo's edge), the nearest it shows, in windows up to 30 cm wide. The back of the head
//! takes the crown's colour (hair, or a bald scalp), not the face's. (Unseen texels facing the
//! front or the sides are left to the mirror and the inpainting: taking the front's median
//! there too cost 0.4–0.8 dB at ±30–90° on the synthetic jacket, whose sides the inpainting
//! continues better.)

use glam::Vec3;

use super::texture::UvTexture;
use super::uv_map::UvMap;
use crate::body::BodyModel;

/// The front image's cell (metres) and the median's half widths in cells, tried in turn (±9 cm,
/// then wider where that window holds no seen texel).
const CELL: f32 = 0.01;
const MEDIAN_RADII: [i32; 3] = [9, 18, 30];
/// A texel faces away from the camera when its rest normal's z is below this.
const FACING_BACK: f32 = -0.2;
/// The crown: the top this many metres of the head the photo shows (the hair, or a cap, or a
/// bald scalp; lower, the forehead would give a bare back of the head).
const CROWN: f32 = 0.03;

/// Per texel of `uv`: a colour for the back where one can be said, else `None` (seen texels,
/// texels facing the front or the sides, back texels 30 cm from anything the front shows); the
/// back of the head takes `crown` ([`crown`]).
pub fn behind(
    body: &BodyModel,
    uv: &UvMap,
    texture: &UvTexture,
    crown: Option<[f32; 3]>,
) -> Vec<Option<[f32; 3]>> {
    let n = (uv.size * uv.size) as usize;
    let mut out = vec![None; n];
    let normals = body.normals_of(&body.vertices);
    let texel = |i: usize| {
        let point = uv.point(i, &body.vertices, &body.triangles);
        let normal = uv.point(i, &normals, &body.triangles);
        let head = body.part_of(uv.nearest_vertex(i, &body.triangles)) == Some("head");
        (point, normal, head)
    };
    let points: Vec<(usize, Vec3, Vec3, bool)> = uv
        .texels
        .iter()
        .map(|&t| {
            let (p, nrm, head) = texel(t as usize);
            (t as usize, p, nrm, head)
        })
        .collect();
    let seen = |i: usize| texture.confidence[i] > 0.0;
    let Some(mut front) = FrontImage::new(&points, texture) else {
        return out;
    };
    for &(i, point, normal, head) in &points {
        if seen(i) {
            continue;
        }
        let back = normal.z < FACING_BACK * normal.length();
        out[i] = match (head, back) {
            (true, true) => crown,
            (false, true) => front.median_near(point),
            (_, false) => None,
        };
    }
    out
}

/// The crown's colour: the median of the seen head texels within [`CROWN`] of the highest seen
/// one (a photo cut through the hair still shows its colour at its top edge); `None` where the
/// photo shows no head.
pub fn crown(body: &BodyModel, uv: &UvMap, texture: &UvTexture) -> Option<[f32; 3]> {
    let seen_head: Vec<(usize, f32)> = uv
        .texels
        .iter()
        .map(|&t| t as usize)
        .filter(|&i| texture.confidence[i] > 0.0)
        .filter(|&i| body.part_of(uv.nearest_vertex(i, &body.triangles)) == Some("head"))
        .map(|i| (i, uv.point(i, &body.vertices, &body.triangles).y))
        .collect();
    let top = seen_head.iter().map(|p| p.1).fold(f32::MIN, f32::max);
    median(
        seen_head
            .iter()
            .filter(|p| p.1 >= top - CROWN)
            .map(|p| texture.rgb[p.0])
            .collect(),
    )
}

/// The seen texels facing the front, drawn orthographically from the front in the rest pose:
/// per cell the colour of the front-most.
struct FrontImage {
    origin: glam::Vec2,
    width: i32,
    height: i32,
    /// Per cell: depth (z) and colour of the front-most seen texel.
    cells: Vec<Option<(f32, [f32; 3])>>,
    /// Per cell, its median once asked for (a back's texels share cells).
    medians: Vec<Option<Option<[f32; 3]>>>,
}

impl FrontImage {
    fn new(points: &[(usize, Vec3, Vec3, bool)], texture: &UvTexture) -> Option<Self> {
        let seen: Vec<&(usize, Vec3, Vec3, bool)> = points
            .iter()
            .filter(|p| texture.confidence[p.0] > 0.0 && p.2.z > 0.0)
            .collect();
        let (lo, hi) = seen
            .iter()
            .fold((glam::Vec2::MAX, glam::Vec2::MIN), |(lo, hi), p| {
                (lo.min(p.1.truncate()), hi.max(p.1.truncate()))
            });
        if seen.is_empty() || !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let size = ((hi - lo) / CELL).ceil().as_ivec2() + 1;
        let mut image = Self {
            origin: lo,
            width: size.x,
            height: size.y,
            cells: vec![None; (size.x * size.y) as usize],
            medians: vec![None; (size.x * size.y) as usize],
        };
        for p in seen {
            let Some(k) = image.index(p.1) else { continue };
            if image.cells[k].is_none_or(|(z, _)| p.1.z > z) {
                image.cells[k] = Some((p.1.z, texture.rgb[p.0]));
            }
        }
        Some(image)
    }

    fn cell(&self, point: Vec3) -> glam::IVec2 {
        ((point.truncate() - self.origin) / CELL).floor().as_ivec2()
    }

    fn index(&self, point: Vec3) -> Option<usize> {
        let c = self.cell(point);
        (c.x >= 0 && c.y >= 0 && c.x < self.width && c.y < self.height)
            .then(|| (c.y * self.width + c.x) as usize)
    }

    /// The median colour of the cells around `point`'s, in the narrowest of [`MEDIAN_RADII`]
    /// that holds a seen texel; `None` where none does (or `point` is off the image).
    fn median_near(&mut self, point: Vec3) -> Option<[f32; 3]> {
        // Off the image (below the photo's edge), from the image's nearest cell: the window
        // still reaches what is seen above it.
        let raw = self.cell(point);
        let c = raw.clamp(
            glam::IVec2::ZERO,
            glam::IVec2::new(self.width - 1, self.height - 1),
        );
        if (raw - c).abs().max_element() > MEDIAN_RADII[MEDIAN_RADII.len() - 1] {
            return None;
        }
        let k = (c.y * self.width + c.x) as usize;
        if let Some(known) = self.medians[k] {
            return known;
        }
        let found = MEDIAN_RADII.iter().find_map(|&r| {
            let mut colours = Vec::new();
            for y in (c.y - r).max(0)..=(c.y + r).min(self.height - 1) {
                for x in (c.x - r).max(0)..=(c.x + r).min(self.width - 1) {
                    if let Some((_, rgb)) = self.cells[(y * self.width + x) as usize] {
                        colours.push(rgb);
                    }
                }
            }
            median(colours)
        });
        self.medians[k] = Some(found);
        found
    }
}

/// The per-channel median of `colours`, `None` for none.
pub(super) fn median(mut colours: Vec<[f32; 3]>) -> Option<[f32; 3]> {
    if colours.is_empty() {
        return None;
    }
    let mid = colours.len() / 2;
    Some([0, 1, 2].map(|c| {
        colours.select_nth_unstable_by(mid, |a, b| a[c].total_cmp(&b[c]));
        colours[mid][c]
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A body seen from the front down to its chest only, the head in one colour and the rest
    /// in another: its back takes the torso's colour, also below the chest where the front
    /// shows nothing (it was left to the inpainting, which brought the hands' skin there), and
    /// the back of its head the crown's.
    #[test]
    fn the_back_takes_the_fronts_colours_also_below_the_photos_edge() {
        let body = BodyModel::default_body().expect("body");
        let uv = UvMap::new(&body.uvs, &body.triangles, 128);
        let (navy, hair) = ([0.1, 0.1, 0.3], [0.4, 0.3, 0.1]);
        let n = (uv.size * uv.size) as usize;
        let mut texture = UvTexture {
            size: uv.size,
            rgb: vec![[0.0; 3]; n],
            confidence: vec![0.0; n],
        };
        let normals = body.normals_of(&body.vertices);
        let neck = body.joints[body.joint_index("neck01").expect("neck")]
            .rest
            .y;
        let chest = neck - 0.2;
        let head = |i: usize| {
            let tri = body.triangles[uv.triangle[i] as usize];
            body.part_of(tri[0] as usize) == Some("head")
        };
        for &t in &uv.texels {
            let i = t as usize;
            let (p, nrm) = (
                uv.point(i, &body.vertices, &body.triangles),
                uv.point(i, &normals, &body.triangles),
            );
            if nrm.z > 0.3 * nrm.length() && p.y > chest {
                texture.rgb[i] = if head(i) { hair } else { navy };
                texture.confidence[i] = 1.0;
            }
        }
        let filled = behind(&body, &uv, &texture, crown(&body, &uv, &texture));
        let (mut below, mut below_filled, mut heads) = (0, 0, 0);
        for &t in &uv.texels {
            let i = t as usize;
            let (p, nrm) = (
                uv.point(i, &body.vertices, &body.triangles),
                uv.point(i, &normals, &body.triangles),
            );
            let back = nrm.z < -0.5 * nrm.length();
            if back && !head(i) && p.y < chest - 0.1 && p.y > chest - 0.3 && p.x.abs() < 0.1 {
                below += 1;
                if filled[i] == Some(navy) {
                    below_filled += 1;
                }
            }
            if back && head(i) && texture.confidence[i] == 0.0 {
                assert_eq!(filled[i], Some(hair), "the back of the head");
                heads += 1;
            }
        }
        println!("{below_filled} of {below} back texels 10–30 cm below the edge; {heads} head");
        assert!(
            below > 50 && below_filled == below,
            "{below_filled} of {below}"
        );
        assert!(heads > 50);
    }
}
