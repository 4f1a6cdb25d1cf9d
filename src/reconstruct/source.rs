//! The source photo as reconstruction sees it: the centred square crop the tracked camera
//! describes, resized (antialiased) to the render size, RGB in [0, 1] multiplied by the person
//! mask (black background, as `data_loader.py` does), plus the mask itself.

use std::path::Path;

use image::{RgbaImage, imageops};

use super::ReconstructError;

/// GUAVA's render and UV-sampling size (`MODEL.image_size`).
pub const SOURCE_SIZE: u32 = 512;
/// Smaller crops carry too little to sample (a 512² map from fewer than 32² pixels is a blur).
pub const MIN_SOURCE_SIDE: u32 = 32;

/// Interleaved RGB planes plus the person mask, `size`² pixels, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceImage {
    pub size: u32,
    /// `rgb[3·i + c]`, already multiplied by the mask.
    pub rgb: Vec<f32>,
    /// Person mask in [0, 1]; `None` until known (no alpha channel and no mask given yet).
    pub mask: Option<Vec<f32>>,
}

impl SourceImage {
    /// Reads a PNG or JPEG; an alpha channel, when present, is the person mask.
    pub fn load(path: &Path) -> Result<Self, ReconstructError> {
        Self::load_at(path, SOURCE_SIZE)
    }

    /// Whether the photo at `path` has an alpha channel (its person mask), read from its header
    /// without decoding the pixels: a photo with one needs no pose model for a mask.
    pub fn has_alpha(path: &Path) -> Result<bool, ReconstructError> {
        use image::ImageDecoder;
        let fail = |e: &dyn std::fmt::Display| ReconstructError::Image {
            file: path.display().to_string(),
            problem: e.to_string(),
        };
        let reader = image::ImageReader::open(path)
            .map_err(|e| fail(&e))?
            .with_guessed_format()
            .map_err(|e| fail(&e))?;
        let decoder = reader.into_decoder().map_err(|e| fail(&e))?;
        Ok(decoder.color_type().has_alpha())
    }

    /// [`Self::load`] at `size`².
    pub fn load_at(path: &Path, size: u32) -> Result<Self, ReconstructError> {
        let (decoded, has_alpha) = Self::decode(path)?;
        Self::from_rgba_at(&decoded, has_alpha, &path.display().to_string(), size)
    }

    /// The photo's pixels and whether it has an alpha channel, for making it at several sizes
    /// ([`Self::from_rgba_at`]) from one decoding.
    pub fn decode(path: &Path) -> Result<(RgbaImage, bool), ReconstructError> {
        let decoded = image::open(path).map_err(|e| ReconstructError::Image {
            file: path.display().to_string(),
            problem: e.to_string(),
        })?;
        let has_alpha = decoded.color().has_alpha();
        Ok((decoded.to_rgba8(), has_alpha))
    }

    /// Crops the centred square, resizes it to [`SOURCE_SIZE`] and applies the alpha as mask when
    /// `use_alpha`. `file` names the image in errors.
    pub fn from_rgba(
        image: &RgbaImage,
        use_alpha: bool,
        file: &str,
    ) -> Result<Self, ReconstructError> {
        Self::from_rgba_at(image, use_alpha, file, SOURCE_SIZE)
    }

    /// [`Self::from_rgba`] at `size`² (GUAVA's encoder takes 518²).
    pub fn from_rgba_at(
        image: &RgbaImage,
        use_alpha: bool,
        file: &str,
        size: u32,
    ) -> Result<Self, ReconstructError> {
        let (w, h) = image.dimensions();
        let side = w.min(h);
        if side < MIN_SOURCE_SIDE {
            return Err(ReconstructError::Image {
                file: file.into(),
                problem: format!(
                    "{w}×{h} pixels: the centred square crop must be at least {MIN_SOURCE_SIDE} pixels"
                ),
            });
        }
        let crop = imageops::crop_imm(image, (w - side) / 2, (h - side) / 2, side, side).to_image();
        // Triangle = bilinear with its support widened by the scale: torchvision's antialias.
        let resized = imageops::resize(&crop, size, size, imageops::FilterType::Triangle);
        let n = (size * size) as usize;
        let mut rgb = Vec::with_capacity(3 * n);
        let mut mask = Vec::with_capacity(n);
        for p in resized.pixels() {
            let a = if use_alpha { p[3] as f32 / 255.0 } else { 1.0 };
            rgb.extend((0..3).map(|c| p[c] as f32 / 255.0 * a));
            mask.push(a);
        }
        if use_alpha && mask.iter().all(|&a| a < 0.5) {
            return Err(ReconstructError::Image {
                file: file.into(),
                problem:
                    "the alpha channel is transparent everywhere: there is no person to reconstruct"
                        .into(),
            });
        }
        Ok(Self {
            size,
            rgb,
            mask: use_alpha.then_some(mask),
        })
    }

    /// Sets the mask when the image had none (the posed body's silhouette) and applies it.
    pub fn apply_mask(&mut self, mask: Vec<f32>) {
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
}
