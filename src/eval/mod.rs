//! How faithful an avatar is to its photo: the avatar re-rendered through the frame path from the
//! view its photo was seen from, compared with the photo × person mask ([`metrics`]): silhouette
//! IoU, and PSNR, SSIM and L1 over the person's box; LPIPS there too with a model the user gives
//! ([`lpips`]).

pub mod lpips;
pub mod metrics;
pub mod pairs;
pub mod subjects;

pub use metrics::Metrics;

use crate::avatar::{Avatar, HandsInView};
use crate::body::{Posable, PosedBody};
use crate::photo::SourceImage;
use crate::refine::Refiner;
use crate::render::{AvatarRenderError, GpuAvatar, HeadlessRenderer, SplatImage};
use crate::tracking::SourceView;

#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error("the photo's mask shows nobody: there is no person to compare with")]
    NoPerson,
    #[error(
        "the avatar does not say which view its photo was seen from (it was saved before version \
         2 of the file): give the photo's tracking file"
    )]
    NoSourceView,
    #[error("the render is {render}² and the photo {photo}²: they must be the same size")]
    Size { render: u32, photo: u32 },
    #[error(transparent)]
    Render(#[from] AvatarRenderError),
    #[error(transparent)]
    Pose(#[from] crate::body::PoseError),
    #[error(transparent)]
    Lpips(#[from] lpips::LpipsError),
    #[error(transparent)]
    Refine(#[from] crate::refine::RefineError),
}

/// `avatar` on `body` as `view` sees it, rendered through the frame path at the view's size on
/// black: posed on the GPU exactly as the viewer poses it.
pub fn render_view(
    renderer: &mut HeadlessRenderer,
    avatar: &Avatar,
    body: &impl Posable,
    view: &SourceView,
) -> Result<SplatImage, EvalError> {
    let mut posed = PosedBody::default();
    body.pose(&view.pose, &mut posed)?;
    let mut gpu = GpuAvatar::new(
        &renderer.gpu.device,
        renderer.pipelines.clone(),
        avatar,
        body.triangles(),
        body.weld(),
    );
    gpu.set_hands(HandsInView::new(avatar, body).map(std::sync::Arc::new));
    let background = vec![0.0; avatar.channels];
    Ok(renderer
        .render_avatar(&mut gpu, &posed, &view.camera, &background)?
        .0)
}

/// How `rendered` (RGB in its first three channels, and its alpha) compares with `photo` (RGB
/// premultiplied by its mask, the same size).
pub fn compare(rendered: &SplatImage, photo: &SourceImage) -> Result<Metrics, EvalError> {
    if (rendered.width, rendered.height) != (photo.size, photo.size) {
        return Err(EvalError::Size {
            render: rendered.width,
            photo: photo.size,
        });
    }
    let size = photo.size as usize;
    let mask = photo.mask.as_deref().ok_or(EvalError::NoPerson)?;
    let bounds = metrics::person_box(mask, size).ok_or(EvalError::NoPerson)?;
    let rgb = interleaved_rgb(rendered);
    Ok(metrics::compare(
        &rgb,
        &rendered.alpha,
        &photo.rgb,
        mask,
        size,
        bounds,
    ))
}

/// LPIPS between `rendered` and `photo` (as [`compare`] takes them) over the person's box.
pub fn perceptual(
    model: &mut lpips::Lpips,
    rendered: &SplatImage,
    photo: &SourceImage,
) -> Result<f64, EvalError> {
    let size = photo.size as usize;
    let mask = photo.mask.as_deref().ok_or(EvalError::NoPerson)?;
    let bounds = metrics::person_box(mask, size).ok_or(EvalError::NoPerson)?;
    let [x0, y0, x1, y1] = bounds;
    let (a, b) = (
        lpips::crop(&interleaved_rgb(rendered), size, bounds),
        lpips::crop(&photo.rgb, size, bounds),
    );
    Ok(model.distance(&a, &b, x1 - x0, y1 - y0)?)
}

/// A render's first three channels (or its one, grey) as interleaved RGB clamped to [0, 1], as
/// the viewer shows them.
pub fn interleaved_rgb(image: &SplatImage) -> Vec<f32> {
    let plane = |c: usize| image.plane(c.min(image.channels - 1));
    let (r, g, b) = (plane(0), plane(1), plane(2));
    (0..r.len())
        .flat_map(|i| [r[i], g[i], b[i]].map(|v| v.clamp(0.0, 1.0)))
        .collect()
}

/// The photo, the render and their absolute difference (×4, so small errors show), side by
/// side as one 8-bit image.
pub fn side_by_side(photo: &SourceImage, rendered: &SplatImage) -> image::RgbImage {
    let size = photo.size;
    let rgb = interleaved_rgb(rendered);
    let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    image::RgbImage::from_fn(3 * size, size, |x, y| {
        let i = 3 * (y * size + x % size) as usize;
        let pixel = |k: usize| match x / size {
            0 => photo.rgb[i + k],
            1 => rgb[i + k],
            _ => 4.0 * (rgb[i + k] - photo.rgb[i + k]).abs(),
        };
        image::Rgb([q(pixel(0)), q(pixel(1)), q(pixel(2))])
    })
}

/// Renders `avatar` from its own source view (or `view` when given), at the photo's size, and
/// compares it with `photo` where it shows the photo. A padded square's padding (a landscape video
/// frame's, a photo framed past its edge) holds no pixels: the render is cleared there as the
/// photo is, so the padding is in neither silhouette nor the person's box (it counted against the
/// IoU as background, and in the box as near-black matches), and what is compared next (LPIPS,
/// the side-by-side) sees the same.
pub fn evaluate(
    renderer: &mut HeadlessRenderer,
    avatar: &Avatar,
    body: &impl Posable,
    view: Option<&SourceView>,
    photo: &SourceImage,
) -> Result<(Metrics, SplatImage), EvalError> {
    evaluate_refined(renderer, avatar, body, view, photo, None)
}

/// [`evaluate`], the render refined by `refiner` first where one is given (as the viewer shows a
/// settled view), the whole frame, before the padding is cleared.
pub fn evaluate_refined(
    renderer: &mut HeadlessRenderer,
    avatar: &Avatar,
    body: &impl Posable,
    view: Option<&SourceView>,
    photo: &SourceImage,
    refiner: Option<&mut Refiner>,
) -> Result<(Metrics, SplatImage), EvalError> {
    let mut view = view
        .or(avatar.source_view.as_ref())
        .ok_or(EvalError::NoSourceView)?
        .clone();
    // GUAVA mode's camera is at its networks' image size; the photo is compared at its own.
    view.camera = view
        .camera
        .scaled(photo.size as f32 / view.camera.width.max(1) as f32);
    let mut rendered = render_view(renderer, avatar, body, &view)?;
    if let Some(refiner) = refiner {
        rendered = refiner.refine(&rendered)?;
    }
    let (size, n) = (photo.size as usize, rendered.alpha.len());
    for i in (0..n).filter(|&i| !photo.shown.contains((i % size) as i64, (i / size) as i64)) {
        rendered.alpha[i] = 0.0;
        rendered.inv_depth[i] = 0.0;
        for c in 0..rendered.channels {
            rendered.features[c * n + i] = 0.0;
        }
    }
    Ok((compare(&rendered, photo)?, rendered))
}
