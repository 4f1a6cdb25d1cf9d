//! Colours for the body's back, which one photo from the front cannot show (default mode). Left
//! to the texture's inpainting, the back took the colours nearest it in the UV map (the neck's
//! and the arms' skin: a bare back under a jacket) or a print mirrored from the front. Here each
//! unseen texel facing away from the camera takes what is in front of it through the body, in
//! the rest pose seen from the front, after a median over a hand's width (so the cloth's colour
//! comes through) that leaves out the prints on the cloth ([`prints`]: a badge wider than half
//! the window came through the median alone, as the demo portrait's purple badge on her back);
//! where the front shows nothing there (below the photo's edge), the nearest it shows, in
//! windows up to 30 cm wide. The back of the head takes the crown's colour (hair, or a bald
//! scalp), not the face's. (Unseen texels facing the front or the sides are left to the mirror
//! and the inpainting: taking the front's median there too cost 0.4–0.8 dB at ±30–90° on the
//! synthetic jacket, whose sides the inpainting continues better.)

use glam::Vec3;

use super::texture::UvTexture;
use super::uv_map::UvMap;
use crate::body::BodyModel;
use crate::photo::distance::{connected_regions, neighbours};

/// The front image's cell (metres) and the median's half widths in cells, tried in turn (±9 cm,
/// then wider where that window holds no seen texel).
const CELL: f32 = 0.01;
const MEDIAN_RADII: [i32; 3] = [9, 18, 30];
/// Prints ([`prints`]): neighbouring cells whose colours differ by this much or more (in any
/// channel) are on different patches; what is not cloth, under [`PRINT_AREA`] (20 × 20 cm) and
/// bordered this share of the way round by one patch of cloth, is printed on it.
const PRINT_EDGE: f32 = 0.1;
pub(super) const PRINT_AREA: f32 = 0.04;
const PRINT_CELLS: usize = (PRINT_AREA / (CELL * CELL) + 0.5) as usize;
const PRINT_ENCLOSED: f32 = 0.6;
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
    let texels: Vec<Texel> = uv
        .texels
        .iter()
        .map(|&t| {
            let i = t as usize;
            let v = uv.nearest_vertex(i, &body.triangles);
            Texel {
                index: i,
                point: uv.point(i, &body.vertices, &body.triangles),
                normal: uv.point(i, &normals, &body.triangles),
                head: body.part_of(v) == Some("head"),
                neck: body.joints[body.dominant_joint(v)].name.starts_with("neck"),
            }
        })
        .collect();
    let seen = |i: usize| texture.confidence[i] > 0.0;
    let Some(mut front) = FrontImage::new(&texels, texture) else {
        return out;
    };
    for t in &texels {
        if seen(t.index) {
            continue;
        }
        let back = t.normal.z < FACING_BACK * t.normal.length();
        out[t.index] = match (t.head, back) {
            (true, true) => crown,
            (false, true) => front.median_near(t.point),
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

/// A texel of the UV map on the body at rest.
struct Texel {
    index: usize,
    point: Vec3,
    normal: Vec3,
    /// On the head; on the neck (bare skin, never a print on the clothes).
    head: bool,
    neck: bool,
}

/// The seen texels facing the front, drawn orthographically from the front in the rest pose:
/// per cell the colour of the front-most.
struct FrontImage {
    origin: glam::Vec2,
    width: i32,
    height: i32,
    /// Per cell: depth (z) and colour of the front-most seen texel.
    cells: Vec<Option<(f32, [f32; 3])>>,
    /// Per cell: whether it is a print on the cloth around it ([`prints`]), which the back does
    /// not take where the window holds that cloth.
    print: Vec<bool>,
    /// Per cell, its median once asked for (a back's texels share cells).
    medians: Vec<Option<Option<[f32; 3]>>>,
}

impl FrontImage {
    fn new(texels: &[Texel], texture: &UvTexture) -> Option<Self> {
        let seen: Vec<&Texel> = texels
            .iter()
            .filter(|t| texture.confidence[t.index] > 0.0 && t.normal.z > 0.0)
            .collect();
        let (lo, hi) = seen
            .iter()
            .fold((glam::Vec2::MAX, glam::Vec2::MIN), |(lo, hi), t| {
                (lo.min(t.point.truncate()), hi.max(t.point.truncate()))
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
            print: Vec::new(),
            medians: vec![None; (size.x * size.y) as usize],
        };
        let mut bare = vec![false; image.cells.len()];
        for t in seen {
            let Some(k) = image.index(t.point) else {
                continue;
            };
            if image.cells[k].is_none_or(|(z, _)| t.point.z > z) {
                image.cells[k] = Some((t.point.z, texture.rgb[t.index]));
                bare[k] = t.head || t.neck;
            }
        }
        let colours: Vec<Option<[f32; 3]>> = image.cells.iter().map(|c| c.map(|c| c.1)).collect();
        let print = prints(&colours, size.x as usize, size.y as usize, PRINT_CELLS);
        // A bare neck in a collar is enclosed by it as a badge is by a jacket.
        image.print = print.iter().zip(&bare).map(|(&p, &b)| p && !b).collect();
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
                    let k = (y * self.width + x) as usize;
                    if let Some((_, rgb)) = self.cells[k] {
                        colours.push((rgb, self.print[k]));
                    }
                }
            }
            cloth_median(colours)
        });
        self.medians[k] = Some(found);
        found
    }
}

/// Per cell of a `width × height` grid of `colours` (`None`: nothing seen there): whether it
/// lies in a print. The cloth is the patches of one colour (cells joined where their colours
/// differ by under [`PRINT_EDGE`]) of `min` cells or more: a smooth change of colour across it
/// is one patch. What is not cloth comes in pieces (cells joined whatever their colours); a
/// piece smaller than `min` and bordered mostly ([`PRINT_ENCLOSED`]) by one patch of cloth is
/// printed on it: a badge, a name tag, a strap across a suit.
pub(super) fn prints(
    colours: &[Option<[f32; 3]>],
    width: usize,
    height: usize,
    min: usize,
) -> Vec<bool> {
    let (patch, sizes) = connected_regions(
        width,
        height,
        |i| colours[i].is_some(),
        |i, j| match (colours[i], colours[j]) {
            (Some(a), Some(b)) => (0..3).all(|k| (a[k] - b[k]).abs() < PRINT_EDGE),
            _ => false,
        },
    );
    let cloth = |i: usize| patch[i] != u32::MAX && sizes[patch[i] as usize] >= min;
    let (piece, pieces) = connected_regions(
        width,
        height,
        |i| colours[i].is_some() && !cloth(i),
        |_, _| true,
    );
    // Per piece, the patches of cloth bordering it with how many cell sides each, and the count
    // of all its border's cell sides (on cloth, on nothing seen, on the image's edge).
    let mut borders: Vec<(Vec<(u32, usize)>, usize)> = vec![(Vec::new(), 0); pieces.len()];
    for i in (0..width * height).filter(|&i| piece[i] != u32::MAX) {
        let (list, total) = &mut borders[piece[i] as usize];
        for j in neighbours(i, width, height) {
            match j {
                Some(j) if piece[j] == piece[i] => continue,
                Some(j) if cloth(j) => match list.iter_mut().find(|(p, _)| *p == patch[j]) {
                    Some((_, n)) => *n += 1,
                    None => list.push((patch[j], 1)),
                },
                _ => {}
            }
            *total += 1;
        }
    }
    let print: Vec<bool> = borders
        .iter()
        .zip(&pieces)
        .map(|((list, total), &size)| {
            size < min
                && list
                    .iter()
                    .any(|&(_, n)| n as f32 >= PRINT_ENCLOSED * *total as f32)
        })
        .collect();
    piece
        .iter()
        .map(|&a| a != u32::MAX && print[a as usize])
        .collect()
}

/// The median of `colours` (each with whether it is a print's) less the prints', or of all of
/// them where all are prints'; `None` for none.
pub(super) fn cloth_median(colours: Vec<([f32; 3], bool)>) -> Option<[f32; 3]> {
    let cloth: Vec<[f32; 3]> = colours.iter().filter(|c| !c.1).map(|c| c.0).collect();
    median(match cloth.is_empty() {
        true => colours.into_iter().map(|c| c.0).collect(),
        false => cloth,
    })
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

    /// The texture of `body` at rest seen from the front down to `chest` (metres, rest y): each
    /// texel facing the front above it in `colour(point, on the head)`.
    fn seen_from_the_front(
        body: &BodyModel,
        uv: &UvMap,
        chest: f32,
        colour: impl Fn(Vec3, bool) -> [f32; 3],
    ) -> UvTexture {
        let n = (uv.size * uv.size) as usize;
        let mut texture = UvTexture {
            size: uv.size,
            rgb: vec![[0.0; 3]; n],
            confidence: vec![0.0; n],
        };
        let normals = body.normals_of(&body.vertices);
        for &t in &uv.texels {
            let i = t as usize;
            let (p, nrm) = (
                uv.point(i, &body.vertices, &body.triangles),
                uv.point(i, &normals, &body.triangles),
            );
            if nrm.z > 0.3 * nrm.length() && p.y > chest {
                texture.rgb[i] = colour(p, on_head(body, uv, i));
                texture.confidence[i] = 1.0;
            }
        }
        texture
    }

    fn on_head(body: &BodyModel, uv: &UvMap, i: usize) -> bool {
        let tri = body.triangles[uv.triangle[i] as usize];
        body.part_of(tri[0] as usize) == Some("head")
    }

    /// The back texels of `body` (rest normal's z below −0.5), not the head's, with their rest
    /// points.
    fn back_texels<'a>(
        body: &'a BodyModel,
        uv: &'a UvMap,
    ) -> impl Iterator<Item = (usize, Vec3)> + 'a {
        let normals = body.normals_of(&body.vertices);
        uv.texels.iter().filter_map(move |&t| {
            let i = t as usize;
            let (p, nrm) = (
                uv.point(i, &body.vertices, &body.triangles),
                uv.point(i, &normals, &body.triangles),
            );
            (nrm.z < -0.5 * nrm.length() && !on_head(body, uv, i)).then_some((i, p))
        })
    }

    fn neck_height(body: &BodyModel) -> f32 {
        body.joints[body.joint_index("neck01").expect("neck")]
            .rest
            .y
    }

    /// A body seen from the front down to its chest only, the head in one colour and the rest
    /// in another: its back takes the torso's colour, also below the chest where the front
    /// shows nothing (it was left to the inpainting, which brought the hands' skin there), and
    /// the back of its head the crown's.
    #[test]
    fn the_back_takes_the_fronts_colours_also_below_the_photos_edge() {
        let body = BodyModel::default_body().expect("body");
        let uv = UvMap::new(&body.uvs, &body.triangles, 128);
        let (navy, hair) = ([0.1, 0.1, 0.3], [0.4, 0.3, 0.1]);
        let chest = neck_height(&body) - 0.2;
        let texture =
            seen_from_the_front(&body, &uv, chest, |_, head| if head { hair } else { navy });
        let filled = behind(&body, &uv, &texture, crown(&body, &uv, &texture));
        let (mut below, mut below_filled) = (0, 0);
        for (i, p) in back_texels(&body, &uv) {
            if p.y < chest - 0.1 && p.y > chest - 0.3 && p.x.abs() < 0.1 {
                below += 1;
                if filled[i] == Some(navy) {
                    below_filled += 1;
                }
            }
        }
        let normals = body.normals_of(&body.vertices);
        let mut heads = 0;
        for &t in &uv.texels {
            let i = t as usize;
            let nrm = uv.point(i, &normals, &body.triangles);
            if nrm.z < -0.5 * nrm.length() && on_head(&body, &uv, i) && texture.confidence[i] == 0.0
            {
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

    /// A purple badge 16 cm across on a navy jacket's chest covers over half of the back's
    /// median window around its middle: the back behind it took the badge's purple (every one
    /// of its texels within 4 cm of the badge's middle, before prints were found) and now takes
    /// the jacket's navy.
    #[test]
    fn a_badge_on_the_chest_does_not_print_on_the_back() {
        let body = BodyModel::default_body().expect("body");
        let uv = UvMap::new(&body.uvs, &body.triangles, 256);
        let (navy, purple, hair) = ([0.1, 0.1, 0.3], [0.5, 0.2, 0.6], [0.4, 0.3, 0.1]);
        let neck = neck_height(&body);
        let badge = glam::Vec2::new(-0.07, neck - 0.12);
        let texture = seen_from_the_front(&body, &uv, neck - 0.3, |p, head| match head {
            true => hair,
            false if p.truncate().distance(badge) < 0.08 => purple,
            false => navy,
        });
        let filled = behind(&body, &uv, &texture, None);
        let behind_badge: Vec<Option<[f32; 3]>> = back_texels(&body, &uv)
            .filter(|(_, p)| p.truncate().distance(badge) < 0.04)
            .map(|(i, _)| filled[i])
            .collect();
        let navy_count = behind_badge.iter().filter(|&&c| c == Some(navy)).count();
        println!(
            "{navy_count} of {} back texels behind the badge navy",
            behind_badge.len()
        );
        assert!(behind_badge.len() > 20);
        assert_eq!(navy_count, behind_badge.len());
    }

    /// A patch enclosed by a larger one is a print; one as large, or half of whose border is
    /// the edge of what was seen, or a smooth change of colour across the cloth, is not.
    #[test]
    fn prints_are_small_patches_enclosed_by_cloth() {
        let (w, h) = (40, 30);
        let at = |x: usize, y: usize| y * w + x;
        // A gradient across the cloth (0.005 a cell), a 4×4 badge inside it, a 4×4 patch in the
        // grid's corner, and a hole (nothing seen) the size of a badge.
        let mut colours: Vec<Option<[f32; 3]>> = (0..w * h)
            .map(|i| Some([0.2 + 0.005 * (i % w) as f32, 0.3, 0.4]))
            .collect();
        for y in 0..4 {
            for x in 0..4 {
                colours[at(x, y)] = Some([0.9, 0.9, 0.1]);
            }
        }
        for y in 10..14 {
            for x in 20..24 {
                colours[at(x, y)] = Some([0.9, 0.1, 0.9]);
            }
            for x in 30..34 {
                colours[at(x, y)] = None;
            }
        }
        let print = prints(&colours, w, h, 100);
        let found: Vec<usize> = (0..w * h).filter(|&i| print[i]).collect();
        let badge: Vec<usize> = (10..14)
            .flat_map(|y| (20..24).map(move |x| at(x, y)))
            .collect();
        assert_eq!(found, badge);
        // Cloth no larger than the badge's bound is not cloth: nothing is printed on it.
        assert!(prints(&colours, w, h, w * h).iter().all(|&p| !p));
    }
}
