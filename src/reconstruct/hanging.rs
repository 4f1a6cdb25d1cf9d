//! Long hair behind the neck (default mode). A front photo shows hair hanging below the skull
//! only as two strips beside the neck; behind the neck it shows nothing, and seen from the side
//! or the back the avatar's neck was bare between the strips, under the shell behind the skull
//! (`hair::shell`). Long hair hangs straight down from the back of the skull and then lies on
//! the back, so each height at which the photo shows both strips gets a row of discs from one
//! strip to the other, each column as far back as the hair behind the body there or above it,
//! in that height's hair colours.

use glam::Vec3;

use crate::camera::Camera;

/// Hair strips narrower than this many pixels on a side are a stray lock, not hanging hair.
const MIN_STRIP: usize = 3;
/// Hanging hair starts at most this far below the skull and has no gap longer than this
/// (metres); shorter than [`MIN_LENGTH`] it is hair ending at the nape, which hangs from nothing
/// (a short cut's ends stood out behind the neck as a bar).
const MAX_GAP: f32 = 0.01;
const MIN_LENGTH: f32 = 0.03;

/// A hair pixel beyond the body: its pixel, where its disc is (world) and its colour.
pub(super) struct Strand {
    pub(super) pixel: usize,
    pub(super) point: Vec3,
    pub(super) rgb: [f32; 3],
}

/// A disc of the curtain: where (world), which way it faces (away from the neck), its colour.
pub(super) struct Disc {
    pub(super) point: Vec3,
    pub(super) normal: Vec3,
    pub(super) rgb: [f32; 3],
}

/// The curtain behind the neck for `hair` (the photo's hair pixels beyond the body, `size`²,
/// seen by `camera`), at the photo's rows from `first_row` down, every `spacing` metres, where
/// the hair shows on both sides of column `middle`: from one side's strip to the other's, each
/// column `thickness` behind the farthest surface of the body (`backs`: the view depths, asked
/// for only where hair hangs) in it at that row or above, as hair hangs straight down from the
/// back of the skull and then lies on the back; its discs `spacing` apart along the row.
#[allow(clippy::too_many_arguments)]
pub(super) fn curtain<'a, 'b>(
    hair: &'a [Strand],
    size: usize,
    camera: &Camera,
    first_row: usize,
    middle: f32,
    backs: impl FnOnce() -> &'b [f32],
    thickness: f32,
    spacing: f32,
) -> Vec<Disc> {
    let view_from_world = camera.view_from_world;
    let world_from_view = view_from_world.inverse();
    let mut rows: Vec<Vec<&'a Strand>> = vec![Vec::new(); size];
    for s in hair {
        rows[s.pixel / size].push(s);
    }
    let column = |s: &Strand| (s.pixel % size) as f32 + 0.5;
    let sides = |row: &[&'a Strand]| -> (Vec<&'a Strand>, Vec<&'a Strand>) {
        row.iter().partition(|s| column(s) < middle)
    };
    let hangs: Vec<bool> = rows
        .iter()
        .map(|row| {
            let (left, right) = sides(row);
            left.len() >= MIN_STRIP && right.len() >= MIN_STRIP
        })
        .collect();
    let Some(run) = hanging_run(
        &hangs,
        first_row,
        camera.pixel_footprint(depth_of(hair, camera)),
    ) else {
        return Vec::new();
    };
    let backs = backs();
    // Per column, the farthest body surface at this row or above: where the hair hangs.
    let mut drape = vec![f32::NEG_INFINITY; size];
    let mut out = Vec::new();
    let mut last_height: Option<f32> = None;
    for (y, row) in rows.iter().enumerate().take(run.end) {
        for (d, &b) in drape.iter_mut().zip(&backs[y * size..(y + 1) * size]) {
            *d = d.max(b + thickness);
        }
        if y < run.start || !hangs[y] {
            continue;
        }
        // One row of discs every `spacing` down the hair (the photo's rows are far closer).
        let height = row.iter().map(|s| s.point.y).sum::<f32>() / row.len() as f32;
        if last_height.is_some_and(|h| (height - h).abs() < spacing) {
            continue;
        }
        last_height = Some(height);
        // From one strip's middle to the other's, in colours going from one's to the other's.
        let (left, right) = sides(row);
        let centre =
            |side: &[&Strand]| side.iter().map(|s| column(s)).sum::<f32>() / side.len() as f32;
        let (from, to) = (centre(&left), centre(&right));
        let (left_rgb, right_rgb) = (median_colour(&left), median_colour(&right));
        // Along the row in quarter pixels, a disc each `spacing` of the draped surface.
        let at = |x: f32| {
            let d = drape[(x as usize).min(size - 1)];
            d.is_finite()
                .then(|| view_from_world.transform_point3(camera.unproject(x, y as f32 + 0.5, d)))
        };
        let mut previous: Option<Vec3> = None;
        let mut travelled = spacing;
        let mut x = from;
        while x <= to {
            let Some(p) = at(x) else {
                (previous, x) = (None, x + 0.25);
                continue;
            };
            travelled += previous.map_or(spacing, |q| q.distance(p));
            if travelled >= spacing {
                travelled = 0.0;
                // Facing away from the camera, square to the row's run about here.
                let ahead = at(x + 1.0).unwrap_or(p);
                let behind = at(x - 1.0).unwrap_or(p);
                let along = (ahead - behind).normalize_or(Vec3::X);
                let outward = along.cross(Vec3::Y).normalize_or(Vec3::Z);
                let outward = if outward.z < 0.0 { -outward } else { outward };
                let t = ((x - from) / (to - from).max(1.0)).clamp(0.0, 1.0);
                out.push(Disc {
                    point: world_from_view.transform_point3(p),
                    normal: world_from_view
                        .transform_vector3(outward)
                        .normalize_or(Vec3::Z),
                    rgb: std::array::from_fn(|c| left_rgb[c] + (right_rgb[c] - left_rgb[c]) * t),
                });
            }
            (previous, x) = (Some(p), x + 0.25);
        }
    }
    out
}

/// The rows of hanging hair among `hangs` (per row, whether hair shows on both sides): the run
/// that starts within [`MAX_GAP`] of `first_row` (the skull's bottom) and goes on with no gap
/// longer than that, if it is at least [`MIN_LENGTH`] long (`footprint` metres a row).
fn hanging_run(hangs: &[bool], first_row: usize, footprint: f32) -> Option<std::ops::Range<usize>> {
    let gap = (MAX_GAP / footprint).ceil() as usize;
    let start = (first_row..hangs.len().min(first_row + gap + 1)).find(|&y| hangs[y])?;
    let mut end = start + 1;
    for (y, &hanging) in hangs.iter().enumerate().skip(start + 1) {
        if y > end + gap {
            break;
        }
        if hanging {
            end = y + 1;
        }
    }
    ((end - start) as f32 * footprint >= MIN_LENGTH).then_some(start..end)
}

/// The mean view depth of the hair pixels.
fn depth_of(hair: &[Strand], camera: &Camera) -> f32 {
    let sum: f32 = hair
        .iter()
        .map(|s| camera.view_from_world.transform_point3(s.point).z)
        .sum();
    sum / hair.len().max(1) as f32
}

/// The per-channel median colour of a strip's hair.
fn median_colour(row: &[&Strand]) -> [f32; 3] {
    std::array::from_fn(|c| {
        let mut v: Vec<f32> = row.iter().map(|s| s.rgb[c]).collect();
        v.sort_by(f32::total_cmp);
        v[v.len() / 2]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hair hanging from the skull down, across short gaps, is one run; hair ending just below
    /// the skull, or starting far below it, is none.
    #[test]
    fn hanging_hair_runs_from_the_skull_down_across_short_gaps() {
        // 1 mm a row: gaps up to 10 rows, at least 30 rows long.
        let run = |hanging: &[(usize, usize)]| {
            let mut hangs = vec![false; 200];
            for &(from, to) in hanging {
                hangs[from..to].fill(true);
            }
            hanging_run(&hangs, 50, 0.001)
        };
        assert_eq!(run(&[(55, 70), (78, 120)]), Some(55..120));
        assert_eq!(
            run(&[(55, 70), (90, 120)]),
            None,
            "15 rows: a short cut's ends"
        );
        assert_eq!(run(&[(70, 150)]), None, "starts 2 cm below the skull");
        assert_eq!(
            run(&[(20, 100)]),
            Some(50..100),
            "above the skull is the shell's"
        );
    }
}
