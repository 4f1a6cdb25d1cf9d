//! Which square of the photo reconstruction sees. A tracked view says (its crop, or the centred
//! square); a photo fitted here is framed around the person ([`Framing`]): in GUAVA mode always
//! with EHM-Tracker's body crop ([`Crop::around`], padded where it passes the photo's edges), as
//! GUAVA's networks learned from such crops; in default mode the centred square is kept when it
//! holds the whole person at a useful size, so a photo its user framed stays as it is. The
//! person is the photo's alpha, else EHM-Tracker's YOLOX box when its models are loaded, else
//! the pose model's mask.

use std::path::Path;

use glam::Vec2;
use image::RgbaImage;

use crate::fit::MIN_PRESENCE;
use crate::keypoints::{Detections, Landmarkers};
use crate::photo::{Crop, PhotoError, SOURCE_SIZE, SourceImage};
use crate::progress::{Stage, check};
use crate::reconstruct::ReconstructError;

/// The share of the person the centred square may leave out before the photo is reframed (a
/// mask's stray edge pixels stay under it).
const MAX_CUT: f32 = 0.01;
/// Below this share of the centred square's side, the person's square is framed instead: the
/// person would get under half the source's pixels across.
const MIN_SHARE: f32 = 0.5;
/// A mask value at or above this is the person.
const PERSON: f32 = 0.5;

/// A person mask over a rectangle of the photo: `width × height` cells, cell `(i, j)` covering
/// `origin + [i, i + 1]·cell × [j, j + 1]·cell` in the photo's pixels.
pub struct PersonMask {
    values: Vec<f32>,
    width: usize,
    origin: Vec2,
    cell: f32,
}

impl PersonMask {
    /// The mask of a square source image (`values`, row-major, a square count) of `crop`.
    pub fn over(crop: Crop, values: Vec<f32>) -> Self {
        let width = (values.len() as f64).sqrt().round() as usize;
        Self {
            cell: crop.side as f32 / width as f32,
            origin: Vec2::new(crop.left as f32, crop.top as f32),
            values,
            width,
        }
    }

    /// The photo's alpha channel, pixel for pixel.
    pub fn alpha(photo: &RgbaImage) -> Self {
        Self {
            values: photo.pixels().map(|p| f32::from(p[3]) / 255.0).collect(),
            width: photo.width() as usize,
            origin: Vec2::ZERO,
            cell: 1.0,
        }
    }

    /// The centres of the person's cells that lie on a `width × height` photo.
    fn person(&self, width: u32, height: u32) -> impl Iterator<Item = Vec2> + '_ {
        let size = Vec2::new(width as f32, height as f32);
        self.values
            .iter()
            .enumerate()
            .filter(|(_, v)| **v >= PERSON)
            .map(|(k, _)| {
                let cell = Vec2::new((k % self.width) as f32, (k / self.width) as f32);
                self.origin + (cell + 0.5) * self.cell
            })
            .filter(move |p| p.cmpge(Vec2::ZERO).all() && p.cmplt(size).all())
    }
}

/// How a fitted photo is framed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Framing {
    /// The centred square unless it cuts the person off or leaves them small (default mode).
    KeepCentred,
    /// EHM-Tracker's body crop around the person, always (GUAVA mode).
    AroundPerson,
}

/// Which square of the photo is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Square {
    /// A tracked view's crop (`None`: the centred square); `points` runs the pose model for
    /// the points the viewer shows even when the photo's alpha is the mask.
    Tracked { crop: Option<Crop>, points: bool },
    /// Framed around the person the keypoint models find, then fitted.
    Fitted(Framing),
}

/// Where the person is on a photo: their box (left, top, right, bottom, in the photo's pixels)
/// and the share of them outside the photo's centred square.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Person {
    pub bounds: [f32; 4],
    pub cut: f32,
}

impl Person {
    /// The person `mask` shows on a `width × height` photo; `None` when it shows nobody.
    pub fn from_mask(mask: &PersonMask, width: u32, height: u32) -> Option<Self> {
        let (low, high) = square_corners(Crop::centred(width, height));
        let (mut min, mut max) = (Vec2::MAX, Vec2::MIN);
        let (mut all, mut inside) = (0usize, 0usize);
        for p in mask.person(width, height) {
            all += 1;
            inside += usize::from(p.cmpge(low).all() && p.cmplt(high).all());
            min = min.min(p - 0.5 * mask.cell);
            max = max.max(p + 0.5 * mask.cell);
        }
        (all > 0).then(|| Self {
            bounds: [min.x, min.y, max.x, max.y],
            cut: (all - inside) as f32 / all as f32,
        })
    }

    /// A person known by their box (EHM-Tracker's YOLOX box); the cut is the share of the box's
    /// area on the photo outside the centred square. `None` when the box misses the photo.
    pub fn from_box(bounds: [f32; 4], width: u32, height: u32) -> Option<Self> {
        let [l, t, r, b] = bounds;
        let area = |(lo, hi): (Vec2, Vec2)| {
            let size = (hi.min(Vec2::new(r, b)) - lo.max(Vec2::new(l, t))).max(Vec2::ZERO);
            size.x * size.y
        };
        let photo = area((Vec2::ZERO, Vec2::new(width as f32, height as f32)));
        let inside = area(square_corners(Crop::centred(width, height)));
        (photo > 0.0).then(|| Self {
            bounds,
            cut: 1.0 - inside / photo,
        })
    }
}

/// A square's top-left and bottom-right corners.
fn square_corners(square: Crop) -> (Vec2, Vec2) {
    let low = Vec2::new(square.left as f32, square.top as f32);
    (low, low + square.side as f32)
}

/// The square to reconstruct a `width × height` photo's `person` from: EHM-Tracker's square
/// around their box, or `None` for the centred square when `framing` keeps it and it holds all
/// but [`MAX_CUT`] of the person, who spans at least [`MIN_SHARE`] of it. `None` too when there
/// is nobody.
pub fn frame(person: Option<Person>, width: u32, height: u32, framing: Framing) -> Option<Crop> {
    let person = person?;
    let around = Crop::around(person.bounds);
    let small = (around.side as f32) < MIN_SHARE * Crop::centred(width, height).side as f32;
    (framing == Framing::AroundPerson || person.cut > MAX_CUT || small).then_some(around)
}

/// The photo as reconstruction reads it: its pixels, the square the view sees at
/// [`SOURCE_SIZE`], and what the keypoint models found there.
pub struct SourcePhoto {
    pub pixels: RgbaImage,
    pub has_alpha: bool,
    /// `None`: the centred square.
    pub crop: Option<Crop>,
    pub image: SourceImage,
    pub detections: Option<Detections>,
}

impl SourcePhoto {
    /// Reads `photo`'s `square`. A tracked square is read as it is, and the pose model alone
    /// runs when `models` are given and the photo has no alpha (with the selfie model, for
    /// the person mask) or the square asks for its points. A fitted one is framed around the person
    /// `models` find ([`frame`]), and every keypoint model runs on the chosen square.
    /// `progress` hears [`Stage::Keypoints`] before each model run.
    pub fn read(
        photo: &Path,
        square: Square,
        models: Option<&mut Landmarkers>,
        progress: &mut dyn FnMut(Stage) -> bool,
    ) -> Result<Self, ReconstructError> {
        let (pixels, has_alpha) = SourceImage::decode(photo)?;
        let file = photo.display().to_string();
        Self::from_pixels(pixels, has_alpha, &file, square, models, progress)
    }

    /// [`Self::read`] of a photo already decoded (`file` names it in errors).
    pub fn from_pixels(
        pixels: RgbaImage,
        has_alpha: bool,
        file: &str,
        square: Square,
        models: Option<&mut Landmarkers>,
        progress: &mut dyn FnMut(Stage) -> bool,
    ) -> Result<Self, ReconstructError> {
        let read = |crop| SourceImage::from_rgba_at(&pixels, crop, has_alpha, file, SOURCE_SIZE);
        let (crop, image, detections) = match (square, models) {
            (Square::Tracked { crop, points }, models) => {
                let image = read(crop)?;
                let detections = match models.filter(|_| points || !has_alpha) {
                    Some(models) => {
                        started(progress)?;
                        Some(models.mask(&image).map_err(keypoint_error)?)
                    }
                    None => None,
                };
                (crop, image, detections)
            }
            (Square::Fitted(framing), Some(models)) => {
                let (crop, image, found) =
                    Self::fit(&pixels, has_alpha, &read, framing, models, progress)?;
                (crop, image, Some(found))
            }
            (Square::Fitted(_), None) => {
                return Err(ReconstructError::Keypoints(
                    "fitting a photo needs the keypoint models, which did not load".into(),
                ));
            }
        };
        Ok(Self {
            pixels,
            has_alpha,
            crop,
            image,
            detections,
        })
    }

    /// Frames the person and detects every keypoint on the chosen square. The alpha frames a
    /// photo that has one before any model runs. Else the person is found on the whole photo
    /// (padded square): EHM-Tracker's YOLOX box when its models are loaded (as its tracker
    /// crops), else the person mask (the selfie and pose models). On a square photo that look is the full detection on
    /// its centred square, run again only on a reframed square; on another the person is looked
    /// for first, and every model runs on the square they are framed in.
    /// `read` makes the source image of a square of `pixels`.
    fn fit(
        pixels: &RgbaImage,
        has_alpha: bool,
        read: &dyn Fn(Option<Crop>) -> Result<SourceImage, PhotoError>,
        framing: Framing,
        models: &mut Landmarkers,
        progress: &mut dyn FnMut(Stage) -> bool,
    ) -> Result<(Option<Crop>, SourceImage, Detections), ReconstructError> {
        let (width, height) = pixels.dimensions();
        let (crop, people) = if has_alpha {
            let person = Person::from_mask(&PersonMask::alpha(pixels), width, height);
            (frame(person, width, height, framing), 0)
        } else {
            let whole = Crop::padded(width, height);
            let image = read(Some(whole))?;
            // Source pixels of the whole photo's square are photo pixels scaled and shifted.
            let on_photo = |[l, t, r, b]: [f32; 4]| {
                let (low, high) = (
                    whole.to_photo(Vec2::new(l, t), SOURCE_SIZE as f32),
                    whole.to_photo(Vec2::new(r, b), SOURCE_SIZE as f32),
                );
                Person::from_box([low.x, low.y, high.x, high.y], width, height)
            };
            // The person mask and the pose model's together: on a person small in a large
            // photo the selfie model (reading the whole photo at 256²) misses the top of the
            // head, and a square framed on its mask alone cut it off. Where the pose model
            // sees nobody (a face close up), its mask is a guess and the selfie model's alone
            // frames them.
            let masked = |found: &Detections| {
                let side = SOURCE_SIZE as usize;
                let person = found.person_mask(side);
                let values = match found.pose.presence >= MIN_PRESENCE {
                    true => (person.iter().zip(found.pose.mask_at(side)))
                        .map(|(a, b)| a.max(b))
                        .collect(),
                    false if found.segmentation.is_some() => person,
                    false => return None,
                };
                Person::from_mask(&PersonMask::over(whole, values), width, height)
            };
            let (person, looked) = if width == height {
                let found = detect(models, &image, progress)?;
                let person = found.person.map_or_else(|| masked(&found), on_photo);
                (person, found)
            } else {
                started(progress)?;
                let found = models.mask(&image).map_err(keypoint_error)?;
                let person = match models.person_box(&image).map_err(keypoint_error)? {
                    Some(boxed) => on_photo(boxed),
                    None => masked(&found),
                };
                (person, found)
            };
            match frame(person, width, height, framing) {
                // The whole square photo is its centred square.
                None if width == height => return Ok((None, image, looked)),
                crop => (crop, looked.pose.people),
            }
        };
        let image = read(crop)?;
        let mut found = detect(models, &image, progress)?;
        // The square framed around the person may leave the others out; the count is the
        // whole photo's.
        found.pose.people = found.pose.people.max(people);
        Ok((crop, image, found))
    }
}

/// Every keypoint model on `image`, once `progress` says go on.
fn detect(
    models: &mut Landmarkers,
    image: &SourceImage,
    progress: &mut dyn FnMut(Stage) -> bool,
) -> Result<Detections, ReconstructError> {
    started(progress)?;
    models.detect(image).map_err(keypoint_error)
}

/// Asks `progress` whether to go on with the keypoint models.
fn started(progress: &mut dyn FnMut(Stage) -> bool) -> Result<(), ReconstructError> {
    Ok(check(Stage::Keypoints, progress)?)
}

fn keypoint_error(e: impl std::fmt::Display) -> ReconstructError {
    ReconstructError::Keypoints(e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photo::MIN_SOURCE_SIDE;

    const KEEP: Framing = Framing::KeepCentred;

    /// A mask over a `width × height` photo with the person on `[l, r) × [t, b)`.
    fn person(width: u32, height: u32, [l, t, r, b]: [u32; 4]) -> Option<Person> {
        let mut photo = RgbaImage::new(width, height);
        for y in t..b {
            for x in l..r {
                photo.put_pixel(x, y, image::Rgba([0, 0, 0, 255]));
            }
        }
        Person::from_mask(&PersonMask::alpha(&photo), width, height)
    }

    #[test]
    fn a_person_inside_the_centred_square_keeps_it() {
        // Wide photo, person centred and filling most of the height.
        assert_eq!(
            frame(person(400, 200, [150, 20, 250, 200]), 400, 200, KEEP),
            None
        );
        // Square photo the person fills, cut by its bottom edge as portraits are.
        assert_eq!(
            frame(person(300, 300, [40, 30, 260, 300]), 300, 300, KEEP),
            None
        );
        assert_eq!(frame(person(300, 300, [0, 0, 0, 0]), 300, 300, KEEP), None);
        // GUAVA mode frames them as EHM-Tracker does all the same.
        let around = Framing::AroundPerson;
        assert_eq!(
            frame(person(300, 300, [40, 30, 260, 300]), 300, 300, around),
            Some(Crop::around([40.0, 30.0, 260.0, 300.0]))
        );
        assert_eq!(
            frame(person(300, 300, [0, 0, 0, 0]), 300, 300, around),
            None
        );
    }

    #[test]
    fn a_person_the_centred_square_cuts_is_framed_as_ehm_tracker_frames_them() {
        // Off-centre in a wide photo: box 100 wide, 180 tall → side 198 around its centre.
        let crop = frame(person(400, 200, [20, 20, 120, 200]), 400, 200, KEEP).expect("reframed");
        assert_eq!(
            crop,
            Crop {
                left: -29,
                top: 11,
                side: 198
            }
        );
        // Tall photo, head near the top: the centred square (its rows 100–300) cuts it.
        let crop = frame(person(200, 400, [30, 20, 170, 400]), 200, 400, KEEP).expect("reframed");
        assert_eq!((crop.side, crop.top), (418, 1));
        // Just under 1 % outside stays; just over is reframed.
        let edge = |cut: u32| person(400, 200, [100 - cut, 0, 300, 200]);
        assert_eq!(
            frame(edge(2), 400, 200, KEEP),
            None,
            "2 of 202 columns: 0.99 %"
        );
        assert!(
            frame(edge(3), 400, 200, KEEP).is_some(),
            "3 of 203 columns: 1.5 %"
        );
    }

    #[test]
    fn a_person_box_is_cut_by_its_area_outside_the_centred_square() {
        // 400×200 photo: the centred square spans x 100…300.
        let cut = |bounds| Person::from_box(bounds, 400, 200).map(|p| p.cut);
        assert_eq!(cut([120.0, 10.0, 280.0, 200.0]), Some(0.0));
        assert_eq!(cut([50.0, 0.0, 150.0, 100.0]), Some(0.5));
        // Only the part on the photo counts: half of this box is above it, none outside x.
        assert_eq!(cut([150.0, -100.0, 250.0, 100.0]), Some(0.0));
        assert_eq!(cut([500.0, 0.0, 600.0, 100.0]), None);
        let person = Person::from_box([20.0, 20.0, 120.0, 200.0], 400, 200);
        assert_eq!(
            frame(person, 400, 200, KEEP),
            Some(Crop::around([20.0, 20.0, 120.0, 200.0]))
        );
    }

    #[test]
    fn a_small_person_is_framed_closer() {
        let crop = frame(person(1000, 1000, [450, 400, 550, 600]), 1000, 1000, KEEP);
        assert_eq!(
            crop,
            Some(Crop {
                left: 390,
                top: 390,
                side: 220
            })
        );
        // A person of a few pixels gets the smallest square reconstruction reads.
        let tiny = frame(person(1000, 1000, [500, 500, 510, 520]), 1000, 1000, KEEP);
        assert_eq!(tiny.map(|c| c.side), Some(MIN_SOURCE_SIDE));
        // At half the square's side or more, the square stays.
        assert_eq!(
            frame(person(1000, 1000, [300, 300, 700, 760]), 1000, 1000, KEEP),
            None
        );
    }

    #[test]
    fn a_source_mask_maps_onto_the_photo_through_its_crop() {
        // A 4² mask of the padded square of a 200×400 photo (side 400, left −100): its cell
        // (1, 0) covers photo x 0–100, y 0–100.
        let mut values = vec![0.0; 16];
        values[1] = 1.0;
        let mask = PersonMask::over(Crop::padded(200, 400), values);
        let cells: Vec<Vec2> = mask.person(200, 400).collect();
        assert_eq!(cells, [Vec2::new(50.0, 50.0)]);
        // Cells of the padding are not the person.
        let mask = PersonMask::over(Crop::padded(200, 400), vec![1.0; 16]);
        assert_eq!(mask.person(200, 400).count(), 8);
    }
}
