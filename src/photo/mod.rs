//! The photo as every stage sees it (the base layer: keypoints, fit and reconstruction all read
//! it): the square of the photo the source camera describes ([`Crop`]; the centred square unless
//! the tracking or the fit says otherwise), resized (antialiased) to the render size, RGB in
//! [0, 1] multiplied by the person mask (black background, as `data_loader.py` does), plus the
//! mask itself; and [`bilinear_clamped`], the sampling every stage shares.

pub mod distance;

use std::path::Path;

use image::{RgbaImage, imageops};

/// A photo that cannot be read or used, naming the file.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}: {problem}")]
pub struct PhotoError {
    pub file: String,
    pub problem: String,
}

/// GUAVA's render and UV-sampling size (`MODEL.image_size`).
pub const SOURCE_SIZE: u32 = 512;
/// Smaller crops carry too little to sample (a 512² map from fewer than 32² pixels is a blur).
pub const MIN_SOURCE_SIDE: u32 = 32;

/// The square of a photo the source camera sees, in the photo's pixels: its top-left corner and
/// side. It may reach past the photo's edges; what lies outside is transparent black, as
/// EHM-Tracker pads its crops (`cv2.warpAffine`'s constant border).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crop {
    pub left: i32,
    pub top: i32,
    pub side: u32,
}

impl Crop {
    /// The largest square centred in a `width × height` photo (what a tracking file without a
    /// crop describes).
    pub fn centred(width: u32, height: u32) -> Self {
        let side = width.min(height);
        Self {
            left: ((width - side) / 2) as i32,
            top: ((height - side) / 2) as i32,
            side,
        }
    }

    /// The smallest square holding the whole photo, centred on it (padded along its shorter side).
    pub fn padded(width: u32, height: u32) -> Self {
        let side = width.max(height);
        Self {
            left: -(((side - width) / 2) as i32),
            top: -(((side - height) / 2) as i32),
            side,
        }
    }

    /// EHM-Tracker's body crop around a person's box (`crop_image_by_bbox`, scale 1.1): a square
    /// 1.1 times the box's longer side, centred on the box, and at least [`MIN_SOURCE_SIDE`].
    /// `bounds` are left, top, right, bottom in the photo's pixels.
    pub fn around(bounds: [f32; 4]) -> Self {
        let [l, t, r, b] = bounds;
        let side = ((r - l).max(b - t) * 1.1)
            .round()
            .max(MIN_SOURCE_SIDE as f32);
        Self {
            left: ((l + r - side) / 2.0).round() as i32,
            top: ((t + b - side) / 2.0).round() as i32,
            side: side as u32,
        }
    }

    /// Photo pixel coordinates of a point given in a `size`² image of this square.
    pub fn to_photo(&self, p: glam::Vec2, size: f32) -> glam::Vec2 {
        glam::Vec2::new(self.left as f32, self.top as f32) + p * (self.side as f32 / size)
    }

    /// `[left, top, side]`, as tracking files store it.
    pub fn to_array(self) -> [i64; 3] {
        [self.left.into(), self.top.into(), self.side.into()]
    }
}

/// The pixels of a square that show the photo: a square reaching past the photo's edges (a
/// video's tracked square, taller than a landscape frame) is padded there, and the padding is
/// neither the person nor the background: what lies there is unknown, as past the square's own
/// border. Pixel `(x, y)` is shown when `left ≤ x < right` and `top ≤ y < bottom`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shown {
    pub left: i64,
    pub top: i64,
    pub right: i64,
    pub bottom: i64,
}

impl Shown {
    /// A whole `size`² square.
    pub fn all(size: u32) -> Self {
        let size = i64::from(size);
        Self {
            left: 0,
            top: 0,
            right: size,
            bottom: size,
        }
    }

    /// Whether pixel `(x, y)` shows the photo.
    pub fn contains(&self, x: i64, y: i64) -> bool {
        (self.left..self.right).contains(&x) && (self.top..self.bottom).contains(&y)
    }
}

/// Interleaved RGB planes plus the person mask, `size`² pixels, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceImage {
    pub size: u32,
    /// `rgb[3·i + c]`, already multiplied by the mask.
    pub rgb: Vec<f32>,
    /// Person mask in [0, 1]; `None` until known (no alpha channel and no mask given yet).
    pub mask: Option<Vec<f32>>,
    /// The pixels that show the photo (the rest is padding: no person, and no background).
    pub shown: Shown,
}

impl SourceImage {
    /// Reads a PNG or JPEG's centred square; an alpha channel, when present, is the person mask.
    pub fn load(path: &Path) -> Result<Self, PhotoError> {
        Self::load_at(path, None, SOURCE_SIZE)
    }

    /// [`Self::load`] of `crop` (`None`: the centred square) at `size`².
    pub fn load_at(path: &Path, crop: Option<Crop>, size: u32) -> Result<Self, PhotoError> {
        let (decoded, has_alpha) = Self::decode(path)?;
        Self::from_rgba_at(&decoded, crop, has_alpha, &path.display().to_string(), size)
    }

    /// The photo's pixels, upright, and whether its alpha channel is a person mask, for making it
    /// at several sizes ([`Self::from_rgba_at`]) from one decoding. Phones store a portrait
    /// sideways with an Exif orientation tag; it is applied here, as every image viewer does. An
    /// alpha channel opaque everywhere (editors and screenshots write them) is no mask: taken as
    /// one, every background pixel became a Gaussian of the person.
    pub fn decode(path: &Path) -> Result<(RgbaImage, bool), PhotoError> {
        use image::ImageDecoder;
        let fail = |e: image::ImageError| PhotoError {
            file: path.display().to_string(),
            problem: e.to_string(),
        };
        let mut decoder = image::ImageReader::open(path)
            .map_err(|e| fail(e.into()))?
            .with_guessed_format()
            .map_err(|e| fail(e.into()))?
            .into_decoder()
            .map_err(fail)?;
        let orientation = decoder.orientation().map_err(fail)?;
        let mut decoded = image::DynamicImage::from_decoder(decoder).map_err(fail)?;
        decoded.apply_orientation(orientation);
        let pixels = decoded.to_rgba8();
        let has_alpha = decoded.color().has_alpha() && pixels.pixels().any(|p| p[3] < u8::MAX);
        Ok((pixels, has_alpha))
    }

    /// Crops the centred square, resizes it to [`SOURCE_SIZE`] and applies the alpha as mask when
    /// `use_alpha`. `file` names the image in errors.
    pub fn from_rgba(image: &RgbaImage, use_alpha: bool, file: &str) -> Result<Self, PhotoError> {
        Self::from_rgba_at(image, None, use_alpha, file, SOURCE_SIZE)
    }

    /// [`Self::from_rgba`] of `crop` (`None`: the centred square) at `size`² (GUAVA's encoder
    /// takes 518²).
    pub fn from_rgba_at(
        image: &RgbaImage,
        crop: Option<Crop>,
        use_alpha: bool,
        file: &str,
        size: u32,
    ) -> Result<Self, PhotoError> {
        let (w, h) = image.dimensions();
        let fail = |problem: String| PhotoError {
            file: file.into(),
            problem,
        };
        let Crop { left, top, side } = crop.unwrap_or(Crop::centred(w, h));
        if side < MIN_SOURCE_SIDE {
            return Err(fail(format!(
                "{w}×{h} pixels: the square crop ({side} pixels) must be at least \
                 {MIN_SOURCE_SIDE} pixels"
            )));
        }
        let (right, bottom) = (
            i64::from(left) + i64::from(side),
            i64::from(top) + i64::from(side),
        );
        if right <= 0 || bottom <= 0 || left >= w as i32 || top >= h as i32 {
            return Err(fail(format!(
                "{w}×{h} pixels: the square crop at ({left}, {top}) of side {side} lies outside the \
                 photo (is the tracking file this photo's?)"
            )));
        }
        let mut square = RgbaImage::new(side, side);
        imageops::replace(&mut square, image, -i64::from(left), -i64::from(top));
        // Triangle = bilinear with its support widened by the scale: torchvision's antialias.
        let resized = imageops::resize(&square, size, size, imageops::FilterType::Triangle);
        let n = (size * size) as usize;
        let mut rgb = Vec::with_capacity(3 * n);
        let mut mask = Vec::with_capacity(n);
        for p in resized.pixels() {
            let a = if use_alpha { p[3] as f32 / 255.0 } else { 1.0 };
            rgb.extend((0..3).map(|c| p[c] as f32 / 255.0 * a));
            mask.push(a);
        }
        if use_alpha && mask.iter().all(|&a| a < 0.5) {
            return Err(PhotoError {
                file: file.into(),
                problem:
                    "the alpha channel is transparent everywhere: there is no person to reconstruct"
                        .into(),
            });
        }
        // The photo's own pixels in the square, at `size`² (a pixel counts when its centre
        // does).
        let scale = f64::from(size) / f64::from(side);
        let at = |v: i64| ((v as f64) * scale).round() as i64;
        let shown = Shown {
            left: at(-i64::from(left)).max(0),
            top: at(-i64::from(top)).max(0),
            right: at(i64::from(w) - i64::from(left)).min(i64::from(size)),
            bottom: at(i64::from(h) - i64::from(top)).min(i64::from(size)),
        };
        Ok(Self {
            size,
            rgb,
            mask: use_alpha.then_some(mask),
            shown,
        })
    }

    /// Sets the mask when the image had none (the posed body's silhouette, a segmentation) and
    /// applies it; the padding is no person, whatever the mask says (a segmentation joins a
    /// black padding to a black top).
    pub fn apply_mask(&mut self, mut mask: Vec<f32>) {
        let size = self.size as usize;
        for (i, m) in mask.iter_mut().enumerate() {
            if !self.shown.contains((i % size) as i64, (i / size) as i64) {
                *m = 0.0;
            }
        }
        for (px, &m) in self.rgb.chunks_exact_mut(3).zip(&mask) {
            px.iter_mut().for_each(|c| *c *= m);
        }
        self.mask = Some(mask);
    }

    /// Pixel `i` (row-major): premultiplied RGB and mask (1 where no mask is known yet).
    pub fn pixel(&self, i: usize) -> ([f32; 3], f32) {
        let rgb = [self.rgb[3 * i], self.rgb[3 * i + 1], self.rgb[3 * i + 2]];
        (rgb, self.mask.as_ref().map_or(1.0, |m| m[i]))
    }

    /// Pixel `i`'s colour with the mask it is premultiplied by divided back out (at most 1).
    pub fn straight(&self, i: usize) -> [f32; 3] {
        let (rgb, m) = self.pixel(i);
        rgb.map(|c| (c / m).min(1.0))
    }
}

/// Bilinear interpolation on a `size`² grid at centre-at-integer `(x, y)`, clamped to the edge;
/// `at` reads texel `row · size + column` (colours, or scalars such as a mask).
pub fn bilinear_clamped<T>(size: usize, x: f32, y: f32, at: impl Fn(usize) -> T) -> T
where
    T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    let lerp = |a: T, b: T, t: f32| a * (1.0 - t) + b * t;
    let max = (size - 1) as f32;
    let (x, y) = (x.clamp(0.0, max), y.clamp(0.0, max));
    // Non-negative here, so the cast is the floor (and no libm call where the target lacks
    // SSE4.1's rounding instructions: it was a tenth of a video's tracking time).
    let (x0, y0) = (x as usize, y as usize);
    let (x1, y1) = ((x0 + 1).min(size - 1), (y0 + 1).min(size - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let top = lerp(at(y0 * size + x0), at(y0 * size + x1), fx);
    let bottom = lerp(at(y1 * size + x0), at(y1 * size + x1), fx);
    lerp(top, bottom, fy)
}

/// Clears the pixels of `mask` (`size`²) nearer a pixel of `others` than one of `person`: where
/// two people touch, one mask of both split between them by their own coarser ones. Nothing is
/// cleared when `person` is empty. Returns how many pixels were cleared.
pub fn keep_nearer(mask: &mut [f32], size: usize, person: &[bool], others: &[bool]) -> usize {
    if !person.contains(&true) {
        return 0;
    }
    let (mine, theirs) = (
        distance::nearest_seeds(person, size),
        distance::nearest_seeds(others, size),
    );
    let mut cleared = 0;
    for ((m, mine), theirs) in mask.iter_mut().zip(mine).zip(theirs) {
        let distance = |d: Option<(f32, u32)>| d.map_or(f32::INFINITY, |(d2, _)| d2);
        if *m > 0.0 && distance(theirs) < distance(mine) {
            *m = 0.0;
            cleared += 1;
        }
    }
    cleared
}

/// Clears the parts of `mask` (`size`², values ≥ ½ being the person) that no pixel of `person`
/// falls in, with a 3-pixel margin of their soft edge, unless none does (then all stay):
/// another person beside the one reconstructed. Returns how many pixels were cleared.
pub fn keep_parts_touching(mask: &mut [f32], size: usize, person: &[bool]) -> usize {
    let inside: Vec<bool> = mask.iter().map(|&m| m >= 0.5).collect();
    let (label, sizes) = distance::connected_parts(&inside, size);
    let mut keep = vec![false; sizes.len()];
    for (&l, &p) in label.iter().zip(person) {
        if l != u32::MAX && p {
            keep[l as usize] = true;
        }
    }
    if !keep.contains(&true) {
        return 0;
    }
    const MARGIN: usize = 3;
    let dropped: Vec<bool> = label
        .iter()
        .map(|&l| l != u32::MAX && !keep[l as usize])
        .collect();
    let near = distance::nearest_seeds(&dropped, size);
    let mut cleared = 0;
    for (i, m) in mask.iter_mut().enumerate() {
        let close =
            near[i].is_some_and(|(d2, _)| d2 <= (MARGIN * MARGIN) as f32 && label[i] == u32::MAX);
        if dropped[i] || (close && *m > 0.0) {
            *m = 0.0;
            cleared += 1;
        }
    }
    cleared
}

/// A part of a person mask apart from its largest part is kept when it is at least this share of
/// the largest (a hand or an arm seen apart from the body); smaller parts are stray pixels of the
/// background the segmentation took for the person.
pub const MIN_PART_SHARE: f32 = 0.02;

/// Clears the parts of `mask` (`size`², values ≥ ½ being the person) smaller than
/// [`MIN_PART_SHARE`] of its largest part; returns how many pixels were cleared.
pub fn keep_person(mask: &mut [f32], size: usize) -> usize {
    let inside: Vec<bool> = mask.iter().map(|&m| m >= 0.5).collect();
    let (label, sizes) = distance::connected_parts(&inside, size);
    let Some(&largest) = sizes.iter().max() else {
        return 0;
    };
    let keep: Vec<bool> = sizes
        .iter()
        .map(|&n| n as f32 >= MIN_PART_SHARE * largest as f32)
        .collect();
    let mut cleared = 0;
    for (m, &l) in mask.iter_mut().zip(&label) {
        if l != u32::MAX && !keep[l as usize] {
            *m = 0.0;
            cleared += 1;
        }
    }
    cleared
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 640×360 frame's tracked square reaches 40 pixels above it and past its bottom and right
    /// edge (the shipped clip's, `[221, -40, 439]`): at 512² the frame's rows are 47 to 466 and
    /// its columns 0 to 488, and a mask that claims the padding is cleared there.
    #[test]
    fn a_padded_squares_padding_shows_nothing() {
        let frame = RgbaImage::from_pixel(640, 360, image::Rgba([200, 150, 100, 255]));
        let crop = Crop {
            left: 221,
            top: -40,
            side: 439,
        };
        let mut photo = SourceImage::from_rgba_at(&frame, Some(crop), false, "frame", SOURCE_SIZE)
            .expect("square");
        let expected = Shown {
            left: 0,
            top: 47,
            right: 489,
            bottom: 467,
        };
        assert_eq!(photo.shown, expected);
        photo.apply_mask(vec![1.0; 512 * 512]);
        let mask = photo.mask.as_ref().expect("a mask");
        for (y, expected) in [(46, 0.0), (47, 1.0), (466, 1.0), (467, 0.0)] {
            assert_eq!(mask[y * 512 + 100], expected, "row {y}");
        }
        assert_eq!(photo.pixel(511 * 512).0, [0.0; 3], "the padding is black");
    }
}
