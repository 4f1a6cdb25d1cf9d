//! Image metrics for how faithful an avatar is to its photo: PSNR, SSIM and mean absolute error
//! of RGB inside the person's box, and the intersection over union of two silhouettes. Images
//! are interleaved RGB in [0, 1] on black (premultiplied by their alpha or mask), `size × size`.
//!
//! SSIM follows Wang et al. 2004 as scikit-image computes it with `gaussian_weights=True`: an
//! 11-tap Gaussian window of σ 1.5, population covariances, C1 = (0.01)², C2 = (0.03)², the mean
//! of the SSIM map over the pixels whose whole window lies in the box, averaged over channels.

/// A silhouette pixel is the person's where its value is at least this.
pub const SILHOUETTE: f32 = 0.5;

/// How one image compares with another over the person.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    /// Silhouette intersection over union (rendered alpha > ½ against the mask > ½).
    pub iou: f64,
    /// Peak signal-to-noise ratio of RGB in the person's box, dB (∞ when identical).
    pub psnr: f64,
    pub ssim: f64,
    /// Mean absolute RGB difference in the person's box.
    pub l1: f64,
    /// The share of the squared RGB error in the box that lies where only one of the two
    /// silhouettes is (the outline's place and shape, against what lies inside both: texture,
    /// shading, expression); 0 when the images agree.
    pub outline: f64,
}

impl std::fmt::Display for Metrics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "iou={:.4} psnr={:.2} ssim={:.4} l1={:.4} outline={:.2}",
            self.iou, self.psnr, self.ssim, self.l1, self.outline
        )
    }
}

/// The smallest box holding every pixel of `mask` (row-major, `size` wide) at or above
/// [`SILHOUETTE`]: `[x0, y0, x1, y1)`. `None` when the mask holds nobody.
pub fn person_box(mask: &[f32], size: usize) -> Option<[usize; 4]> {
    let mut b = [usize::MAX, usize::MAX, 0, 0];
    for (i, _) in mask.iter().enumerate().filter(|(_, m)| **m >= SILHOUETTE) {
        let (x, y) = (i % size, i / size);
        b = [b[0].min(x), b[1].min(y), b[2].max(x + 1), b[3].max(y + 1)];
    }
    (b[2] > 0).then_some(b)
}

/// Intersection over union of two silhouettes (each value thresholded at [`SILHOUETTE`]); 1 when
/// both are empty.
pub fn iou(a: &[f32], b: &[f32]) -> f64 {
    let (mut both, mut either) = (0usize, 0usize);
    for (&x, &y) in a.iter().zip(b) {
        let (x, y) = (x >= SILHOUETTE, y >= SILHOUETTE);
        both += usize::from(x && y);
        either += usize::from(x || y);
    }
    if either == 0 {
        1.0
    } else {
        both as f64 / either as f64
    }
}

/// PSNR, SSIM and L1 of `a` against `b` (RGB, `size` wide) inside `bounds`, with the IoU of
/// their silhouettes.
pub fn compare(
    a: &[f32],
    a_alpha: &[f32],
    b: &[f32],
    b_mask: &[f32],
    size: usize,
    bounds: [usize; 4],
) -> Metrics {
    let [x0, y0, x1, y1] = bounds;
    let (mut se, mut ae, mut n, mut outline) = (0.0f64, 0.0f64, 0usize, 0.0f64);
    for y in y0..y1 {
        for x in x0..x1 {
            let p = y * size + x;
            let one_side = (a_alpha[p] >= SILHOUETTE) != (b_mask[p] >= SILHOUETTE);
            for c in 0..3 {
                let i = 3 * p + c;
                let d = (a[i] - b[i]) as f64;
                se += d * d;
                ae += d.abs();
                n += 1;
                if one_side {
                    outline += d * d;
                }
            }
        }
    }
    let mse = se / n.max(1) as f64;
    Metrics {
        iou: iou(a_alpha, b_mask),
        psnr: if mse == 0.0 {
            f64::INFINITY
        } else {
            -10.0 * mse.log10()
        },
        ssim: (0..3)
            .map(|c| ssim_channel(a, b, c, size, bounds))
            .sum::<f64>()
            / 3.0,
        l1: ae / n.max(1) as f64,
        outline: if se > 0.0 { outline / se } else { 0.0 },
    }
}

const WINDOW: usize = 11;
const SIGMA: f64 = 1.5;
const C1: f64 = 0.01 * 0.01;
const C2: f64 = 0.03 * 0.03;

/// Mean SSIM of channel `c` over the box's pixels whose window fits in the box (one window over
/// the whole box when it is smaller than a window).
fn ssim_channel(a: &[f32], b: &[f32], c: usize, size: usize, bounds: [usize; 4]) -> f64 {
    let weights: Vec<f64> = {
        let r = (WINDOW / 2) as f64;
        let w: Vec<f64> = (0..WINDOW)
            .map(|k| (-(k as f64 - r).powi(2) / (2.0 * SIGMA * SIGMA)).exp())
            .collect();
        let sum: f64 = w.iter().sum();
        w.iter().map(|v| v / sum).collect()
    };
    let [x0, y0, x1, y1] = bounds;
    let (w, h) = (x1 - x0, y1 - y0);
    let at = |img: &[f32], x: usize, y: usize| img[3 * ((y0 + y) * size + x0 + x) + c] as f64;
    // Separable filtering of a, b, a², b², ab over the box, horizontal then vertical.
    let half = WINDOW / 2;
    if w < WINDOW || h < WINDOW {
        // One window, the whole box, unweighted.
        let n = (w * h).max(1) as f64;
        let mut s = [0.0; 5];
        for y in 0..h {
            for x in 0..w {
                let (p, q) = (at(a, x, y), at(b, x, y));
                for (acc, v) in s.iter_mut().zip([p, q, p * p, q * q, p * q]) {
                    *acc += v / n;
                }
            }
        }
        return ssim_of(s);
    }
    let fields = |x: usize, y: usize| {
        let (p, q) = (at(a, x, y), at(b, x, y));
        [p, q, p * p, q * q, p * q]
    };
    let mut rows = vec![[0.0f64; 5]; (w - 2 * half) * h];
    for y in 0..h {
        for x in half..w - half {
            let mut s = [0.0; 5];
            for (k, wk) in weights.iter().enumerate() {
                let f = fields(x + k - half, y);
                for (acc, v) in s.iter_mut().zip(f) {
                    *acc += wk * v;
                }
            }
            rows[y * (w - 2 * half) + x - half] = s;
        }
    }
    let ww = w - 2 * half;
    let (mut total, mut count) = (0.0, 0usize);
    for y in half..h - half {
        for x in 0..ww {
            let mut s = [0.0; 5];
            for (k, wk) in weights.iter().enumerate() {
                let r = rows[(y + k - half) * ww + x];
                for (acc, v) in s.iter_mut().zip(r) {
                    *acc += wk * v;
                }
            }
            total += ssim_of(s);
            count += 1;
        }
    }
    total / count as f64
}

/// SSIM of one window from its means of a, b, a², b² and ab.
fn ssim_of([ma, mb, saa, sbb, sab]: [f64; 5]) -> f64 {
    let (va, vb, cov) = (saa - ma * ma, sbb - mb * mb, sab - ma * mb);
    ((2.0 * ma * mb + C1) * (2.0 * cov + C2)) / ((ma * ma + mb * mb + C1) * (va + vb + C2))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pattern(size: usize, shift: f32) -> Vec<f32> {
        (0..size * size * 3)
            .map(|i| {
                let (p, c) = (i / 3, i % 3);
                let (x, y) = ((p % size) as f32, (p / size) as f32);
                0.5 + 0.4 * ((x + shift) * 0.3 + c as f32).sin() * (y * 0.2).cos()
            })
            .collect()
    }

    fn square(size: usize, x0: usize, y0: usize, side: usize) -> Vec<f32> {
        (0..size * size)
            .map(|i| {
                let (x, y) = (i % size, i / size);
                f32::from(x >= x0 && x < x0 + side && y >= y0 && y < y0 + side)
            })
            .collect()
    }

    #[test]
    fn identical_images_are_perfect() {
        let (size, img) = (40, pattern(40, 0.0));
        let mask = square(size, 5, 5, 30);
        let bounds = person_box(&mask, size).expect("a person");
        assert_eq!(bounds, [5, 5, 35, 35]);
        let m = compare(&img, &mask, &img, &mask, size, bounds);
        assert_eq!((m.iou, m.l1, m.outline), (1.0, 0.0, 0.0));
        assert!(m.psnr.is_infinite() && (m.ssim - 1.0).abs() < 1e-12, "{m}");
    }

    #[test]
    fn a_shifted_mask_has_the_known_iou() {
        // Two 20×20 squares, one shifted 5 px right: 15·20 shared, 25·20 in either.
        let a = square(40, 5, 5, 20);
        let b = square(40, 10, 5, 20);
        assert!((iou(&a, &b) - 300.0 / 500.0).abs() < 1e-12);
        assert_eq!(iou(&square(40, 0, 0, 0), &square(40, 0, 0, 0)), 1.0);
        assert_eq!(person_box(&square(40, 0, 0, 0), 40), None);
    }

    #[test]
    fn the_outline_share_splits_the_error_by_where_it_lies() {
        // The render's square is 5 px narrower than the photo's: a 5×20 strip only the photo
        // covers, where the render is black.
        let size = 40;
        let (photo_mask, render_alpha) = (square(size, 5, 5, 20), square(size, 5, 5, 20));
        let mut render_alpha_narrow = render_alpha.clone();
        for y in 5..25 {
            for x in 20..25 {
                render_alpha_narrow[y * size + x] = 0.0;
            }
        }
        let premultiplied = |rgb: f32, alpha: &[f32]| -> Vec<f32> {
            alpha.iter().flat_map(|&a| [rgb * a; 3]).collect()
        };
        let photo = premultiplied(0.5, &photo_mask);
        let bounds = person_box(&photo_mask, size).expect("a person");
        // Alone, the outline's strip holds all the error.
        let narrow = premultiplied(0.5, &render_alpha_narrow);
        let m = compare(
            &narrow,
            &render_alpha_narrow,
            &photo,
            &photo_mask,
            size,
            bounds,
        );
        assert!((m.outline - 1.0).abs() < 1e-12, "{m}");
        // The same strip with the inside off by 0.1: 100 pixels at 0.5² against 300 at 0.1².
        let darker: Vec<f32> = narrow
            .iter()
            .zip(&photo)
            .map(|(&r, &p)| if r > 0.0 { p - 0.1 } else { r })
            .collect();
        let m = compare(
            &darker,
            &render_alpha_narrow,
            &photo,
            &photo_mask,
            size,
            bounds,
        );
        let expected = 100.0 * 0.25 / (100.0 * 0.25 + 300.0 * 0.01);
        assert!((m.outline - expected).abs() < 1e-6, "{m} {expected}");
        // The same outlines and only the inside off: none of it.
        let inside: Vec<f32> = photo
            .iter()
            .map(|&p| if p > 0.0 { p - 0.1 } else { p })
            .collect();
        let m = compare(&inside, &render_alpha, &photo, &photo_mask, size, bounds);
        assert_eq!(m.outline, 0.0, "{m}");
    }

    #[test]
    fn psnr_of_a_constant_offset_and_ssim_falls_with_noise() {
        let size = 32;
        let a = vec![0.5f32; size * size * 3];
        let b = vec![0.6f32; size * size * 3];
        let mask = vec![1.0; size * size];
        let all = [0, 0, size, size];
        let m = compare(&a, &mask, &b, &mask, size, all);
        // MSE 0.01 → 20 dB; L1 0.1.
        assert!(
            (m.psnr - 20.0).abs() < 1e-4 && (m.l1 - 0.1).abs() < 1e-6,
            "{m}"
        );
        let (p, q) = (pattern(size, 0.0), pattern(size, 3.0));
        let close = compare(&p, &mask, &pattern(size, 0.2), &mask, size, all).ssim;
        let far = compare(&p, &mask, &q, &mask, size, all).ssim;
        assert!(1.0 > close && close > far, "{close} {far}");
    }
}
