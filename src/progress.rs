//! Progress and cancellation of long work (photo → avatar): the stages a job goes through, in
//! order, and a clock that times each one and asks the caller whether to go on. Every stage of
//! the pipeline reports through these, so the CLI and the viewer show the same names.

use std::time::{Duration, Instant};

/// The stages of making an avatar from a photo, in the order they run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Loading the keypoint models (once per session; kept for the next photo).
    LoadModels,
    /// The keypoint models on the photo: person, body, face, irises, hands, mask.
    Keypoints,
    /// The body's pose, shape, expression and camera fitted to the keypoints.
    Fit,
    /// The fitted body's outline fitted to the person mask.
    Silhouette,
    /// GUAVA mode: DINOv2 and its feature head on the photo.
    Encode,
    Pose,
    /// The clothing layer: offsets from the body fitted to the person's silhouette.
    Dress,
    Rasterize,
    TextureMap,
    Fill,
    /// GUAVA mode: the template-Gaussian decoder.
    DecodeVertices,
    /// GUAVA mode: the UV StyleUNet and its Gaussian heads.
    DecodeUv,
    Gaussians,
    /// Gaussians for the person's pixels the body does not cover (hair, loose clothing).
    Extras,
}

impl Stage {
    /// The stages of the default reconstruction proper (after the photo's view is known).
    pub const DEFAULT: [Stage; 7] = [
        Stage::Pose,
        Stage::Dress,
        Stage::Rasterize,
        Stage::TextureMap,
        Stage::Fill,
        Stage::Gaussians,
        Stage::Extras,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::LoadModels => "loading the keypoint models",
            Stage::Keypoints => "keypoints and person mask",
            Stage::Fit => "fit pose, shape and camera",
            Stage::Silhouette => "fit the outline to the mask",
            Stage::Encode => "encoder (DINOv2, feature maps)",
            Stage::DecodeVertices => "template-Gaussian decoder",
            Stage::DecodeUv => "UV decoder (StyleUNet)",
            Stage::Pose => "pose source body",
            Stage::Dress => "clothing to the silhouette",
            Stage::Rasterize => "rasterize (visibility, mask)",
            Stage::TextureMap => "inverse texture mapping",
            Stage::Fill => "fill (mirror, push-pull)",
            Stage::Gaussians => "build Gaussians",
            Stage::Extras => "Gaussians beyond the body",
        }
    }
}

/// The caller said stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("cancelled")]
pub struct Cancelled;

/// Asks `progress` whether to go on into `stage`.
pub fn check(stage: Stage, progress: &mut dyn FnMut(Stage) -> bool) -> Result<(), Cancelled> {
    if progress(stage) {
        Ok(())
    } else {
        Err(Cancelled)
    }
}

/// Times consecutive stages and asks the progress callback whether to go on.
#[derive(Default)]
pub struct StageClock {
    current: Option<(Stage, Instant)>,
    done: Vec<(Stage, Duration)>,
}

impl StageClock {
    /// Ends the running stage and starts `stage`, unless `progress` says stop.
    pub fn start(
        &mut self,
        stage: Stage,
        progress: &mut dyn FnMut(Stage) -> bool,
    ) -> Result<(), Cancelled> {
        self.stop();
        check(stage, progress)?;
        self.current = Some((stage, Instant::now()));
        Ok(())
    }

    fn stop(&mut self) {
        if let Some((stage, t)) = self.current.take() {
            self.done.push((stage, t.elapsed()));
        }
    }

    /// Each stage with its time, in order.
    pub fn finish(mut self) -> Vec<(Stage, Duration)> {
        self.stop();
        self.done
    }
}
