//! Where the face model's points lie on a body. The default body has no face-mesh landmarks
//! (Anny ships only COCO body points), so they are found the way a person would mark them: show
//! the face model the body's own rest face, drawn shaded from the front, and carry each point it
//! finds back to the surface under it (triangle and barycentrics). Any body template with eyes,
//! nose and a face gets its embedding this way; it takes one render and one model run.

use glam::{Vec2, Vec3};

use super::FitError;
use crate::body::{BodyModel, Landmark};
use crate::camera::Camera;
use crate::keypoints::{FACE_INPUT, FaceLandmarker};
use crate::raster::{Fragments, rasterize};
use crate::synthetic::shaded;

/// The face-mesh points the fit uses: lip contours (outer and inner), eye contours, brows, the
/// nose's ridge, tip and wings, and the chin. The face's outline is left out: on a turned head it
/// slides along the silhouette and marks no fixed surface point.
pub const FACE_FIT_POINTS: &[usize] = &[
    // Lips, outer then inner.
    61, 146, 91, 181, 84, 17, 314, 405, 321, 375, 291, 185, 40, 39, 37, 0, 267, 269, 270, 409, 78,
    95, 88, 178, 87, 14, 317, 402, 318, 324, 308, 191, 80, 81, 82, 13, 312, 311, 310, 415,
    // Subject's left eye, then right eye.
    263, 249, 390, 373, 374, 380, 381, 382, 362, 466, 388, 387, 386, 385, 384, 398, 33, 7, 163, 144,
    145, 153, 154, 155, 133, 246, 161, 160, 159, 158, 157, 173,
    // Brows, left then right.
    276, 283, 282, 295, 285, 300, 293, 334, 296, 336, 46, 53, 52, 65, 55, 70, 63, 105, 66, 107,
    // Nose and chin.
    168, 6, 197, 195, 5, 4, 1, 2, 98, 327, 152,
];

/// The features of [`FACE_FIT_POINTS`] (ranges into it); the chin belongs to none.
pub const FACE_FEATURES: [(&str, std::ops::Range<usize>); 6] = [
    ("lips", 0..40),
    ("left eye", 40..56),
    ("right eye", 56..72),
    ("left brow", 72..82),
    ("right brow", 82..92),
    ("nose", 92..102),
];

/// The calibration camera: close enough for a face-sized perspective (a photo from ~0.5 m).
const INVTANFOV: f32 = 4.0;
/// Rendered at twice the model's input and box-filtered down, so edges are antialiased.
const SUPERSAMPLE: u32 = 2;
/// How far (render pixels) a point may be moved to the nearest skin.
const SEARCH: i64 = 6;
/// The crop spans this many eye distances, as [`crate::keypoints::Roi::face_from_pose`] frames it.
const SIDE_PER_EYE_DISTANCE: f32 = 4.5;

/// The body's surface points for [`FACE_FIT_POINTS`], in that order.
#[derive(Clone, Debug)]
pub struct FaceEmbedding {
    pub points: Vec<Landmark>,
    /// The face model's presence on the rendered face (how face-like it found it).
    pub presence: f32,
}

/// Shades the rest body's face from the front, runs the face model on it and maps each used
/// point back onto the surface.
pub fn embed_face(body: &BodyModel, model: &mut FaceLandmarker) -> Result<FaceEmbedding, FitError> {
    let rest = body.landmark_positions(&body.vertices);
    let landmark = |name: &str| {
        let l = body
            .landmarks
            .iter()
            .position(|l| l.name == name)
            .ok_or_else(|| FitError::MissingOnBody(name.into()))?;
        Ok::<_, FitError>(rest[l])
    };
    let (left, right, nose) = (
        landmark("left_eye")?,
        landmark("right_eye")?,
        landmark("nose")?,
    );
    let eyes = 0.5 * (left + right);
    let target = eyes + 0.5 * (nose - eyes);
    let side = SIDE_PER_EYE_DISTANCE * left.distance(right);
    let eye = target + Vec3::Z * (side * INVTANFOV / 2.0);
    let camera = Camera::guava(
        Camera::look_at(eye, target, Vec3::Y),
        FACE_INPUT as u32 * SUPERSAMPLE,
        INVTANFOV,
    );
    let fragments = rasterize(&body.vertices, &body.triangles, &camera);
    let input = shaded(
        body,
        &body.vertices,
        &fragments,
        (eye - target).normalize(),
        SUPERSAMPLE as usize,
    );
    let (found, presence) = model
        .run(&input)
        .map_err(|e| FitError::FaceModel(e.to_string()))?;
    if presence < 0.5 {
        return Err(FitError::FaceModel(format!(
            "the face model finds no face on the body's own rendered face (presence {presence:.2}); its face points cannot be placed"
        )));
    }
    let points = FACE_FIT_POINTS
        .iter()
        .map(|&i| {
            let p = Vec2::new(found[i][0], found[i][1]) * SUPERSAMPLE as f32;
            surface_under(body, &fragments, p, i)
        })
        .collect::<Result<_, _>>()?;
    Ok(FaceEmbedding { points, presence })
}

/// Parts a face point never sits on: the model's eye and lip contours mark the lid and lip
/// margins, which move with blinks and smiles, while the eyeballs and the mouth's inside do not.
fn is_skin(body: &BodyModel, triangle: [u32; 3]) -> bool {
    triangle.iter().all(|&v| {
        !body
            .part_of(v as usize)
            .is_some_and(|p| p.starts_with("eye") || p == "mouth_cavity" || p == "tongue")
    })
}

/// The skin point drawn at pixel `p` of the calibration render, or the nearest skin pixel within
/// a few pixels (for points the model puts on an eye, inside the mouth or just off the face).
fn surface_under(
    body: &BodyModel,
    f: &Fragments,
    p: Vec2,
    index: usize,
) -> Result<Landmark, FitError> {
    let (x0, y0) = (p.x.floor() as i64, p.y.floor() as i64);
    let mut best: Option<(i64, usize)> = None;
    for dy in -SEARCH..=SEARCH {
        for dx in -SEARCH..=SEARCH {
            let (x, y) = (x0 + dx, y0 + dy);
            if x < 0 || y < 0 || x >= f.width as i64 || y >= f.height as i64 {
                continue;
            }
            let i = f.index(x as u32, y as u32);
            let d = dx * dx + dy * dy;
            let skin = f.triangle[i] >= 0 && is_skin(body, body.triangles[f.triangle[i] as usize]);
            if skin && best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, i));
            }
        }
    }
    let (_, i) = best.ok_or_else(|| {
        FitError::FaceModel(format!(
            "face point {index} has no skin of the body's rendered face near ({:.0}, {:.0})",
            p.x, p.y
        ))
    })?;
    let tri = body.triangles[f.triangle[i] as usize];
    Ok(Landmark {
        name: format!("face_mesh_{index}"),
        vertices: tri.to_vec(),
        weights: f.bary[i].to_vec(),
    })
}
