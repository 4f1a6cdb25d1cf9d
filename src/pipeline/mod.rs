//! Photo → avatar, for both modes, in one place: the CLI (`guava reconstruct`, `guava fit`) and
//! the viewer's worker call the same code, so they load models, read photos, fit and report
//! alike.
//!
//! Stages, each timed and cancellable ([`crate::progress`]): read the photo → load the keypoint
//! models when the photo needs them (kept for the next photo) → keypoints and framing → the
//! source view (a tracking file's frame 0, a fit to the keypoints, or given) → the person mask
//! (the photo's alpha, else the selfie and pose models' person segmentation, else — default mode only — the
//! body's silhouette) → the reconstruction proper ([`crate::reconstruct`] on a body template,
//! [`crate::guava_mode`] with GUAVA's networks on EHM).

mod framing;
mod keypoint_models;
mod report;

pub use framing::{Framing, Person, PersonMask, SourcePhoto, Square, frame};
pub use keypoint_models::KeypointModels;
pub use report::{MaskSource, Report, fit_lines};

use std::path::{Path, PathBuf};
use std::sync::Arc;

use image::RgbaImage;

use crate::avatar::Avatar;
use crate::body::{BodyModel, BodyRef, EhmIdentity, EhmModel, Posable};
use crate::fit::{FitError, fit_detections, fit_ehm_detections, fit_silhouette};
use crate::guava_mode::{GuavaModels, reconstruct_guava, uv_map};
use crate::keypoints::{Detections, Landmarkers};
use crate::photo::{PhotoError, SOURCE_SIZE, SourceImage};
use crate::progress::{Stage, StageClock};
use crate::reconstruct::{DEFAULT_UV_SIZE, ReconstructError, UvMap, reconstruct_default};
use crate::tracking::{EhmIdentityRecord, SourceView, Tracking};

/// The body an avatar is made on, and with what.
pub enum Mode<'a> {
    /// The default reconstruction on a body template (no learned weights).
    Default(&'a BodyModel),
    /// GUAVA's networks on its EHM body.
    Guava {
        body: &'a EhmModel,
        networks: &'a mut GuavaModels,
    },
}

impl<'a> Mode<'a> {
    fn fit_body(&self) -> BodyRef<'_> {
        match self {
            Mode::Default(body) => BodyRef::Template(body),
            Mode::Guava { body, .. } => BodyRef::Ehm(body),
        }
    }
}

/// How the photo's pose and camera are known.
pub enum Tracked {
    /// A tracking file (frame 0).
    File(PathBuf),
    /// Fitted here to the keypoint models' points.
    Fit,
    /// Given as it is (a fit adjusted by hand in the viewer).
    Given(SourceView),
}

impl Tracked {
    /// The tracking file beside `photo` when there is one (same folder and stem, `.json`), else a
    /// fit.
    pub fn beside(photo: &Path) -> Self {
        let file = tracking_beside(photo);
        if file.is_file() {
            Self::File(file)
        } else {
            Self::Fit
        }
    }
}

/// The tracking file that goes with a photo when none is named: same folder and stem, `.json`.
pub fn tracking_beside(photo: &Path) -> PathBuf {
    photo.with_extension("json")
}

/// A photo to make an avatar of: a file, or pixels made in memory (a synthetic photo).
pub enum Photo<'a> {
    File(&'a Path),
    Pixels {
        /// What the avatar and errors call it.
        name: &'a str,
        pixels: RgbaImage,
        /// Whether the alpha channel is the person mask.
        has_alpha: bool,
    },
}

impl Photo<'_> {
    fn name(&self) -> String {
        match self {
            Photo::File(path) => path.display().to_string(),
            Photo::Pixels { name, .. } => (*name).into(),
        }
    }

    /// The name the avatar keeps: the file's name without its folder.
    fn source_name(&self) -> String {
        match self {
            Photo::File(path) => path
                .file_name()
                .map_or_else(|| self.name(), |n| n.to_string_lossy().into_owned()),
            Photo::Pixels { name, .. } => (*name).into(),
        }
    }

    fn decode(self) -> Result<(RgbaImage, bool), PhotoError> {
        match self {
            Photo::File(path) => SourceImage::decode(path),
            Photo::Pixels {
                pixels, has_alpha, ..
            } => Ok((pixels, has_alpha)),
        }
    }
}

/// A photo's view, found: the photo as read (its square at [`SOURCE_SIZE`], masked), the source
/// view and how it was found.
pub struct Source {
    pub photo: SourcePhoto,
    pub view: SourceView,
    /// The tracking file's EHM skeleton (GUAVA mode builds the body with it).
    pub ehm_identity: Option<EhmIdentity>,
    pub report: Report,
}

/// `image` masked by its alpha, else by the person mask of `detections`
/// ([`Detections::person_mask`]): what an avatar is made from and compared with.
fn with_person_mask(mut image: SourceImage, detections: Option<&Detections>) -> SourceImage {
    if let (None, Some(d)) = (&image.mask, detections) {
        image.apply_mask(d.person_mask(image.size as usize));
    }
    image
}

/// A finished reconstruction.
pub struct Outcome {
    pub avatar: Avatar,
    pub view: SourceView,
    /// The photo as `view` sees it at [`SOURCE_SIZE`], masked (what the avatar is compared with;
    /// no mask when neither its alpha nor the pose model gave one).
    pub photo: SourceImage,
    pub report: Report,
}

/// What a session keeps between photos: the keypoint models and the last body's UV map.
pub struct Pipeline {
    pub keypoints: KeypointModels,
    /// The default reconstruction's UV map side (a quality knob: texels become Gaussians).
    pub uv_size: u32,
    uv: Option<(UvKey, Arc<UvMap>)>,
}

/// Which body and size a UV map is of.
#[derive(Clone, PartialEq)]
struct UvKey {
    body: String,
    vertices: usize,
    size: u32,
}

impl Default for Pipeline {
    fn default() -> Self {
        Self::new(KeypointModels::default())
    }
}

impl Pipeline {
    pub fn new(keypoints: KeypointModels) -> Self {
        Self {
            keypoints,
            uv_size: DEFAULT_UV_SIZE,
            uv: None,
        }
    }

    /// Reads `photo` and finds its view on `body`: `tracked` says how. A fitted photo is framed
    /// around the person (`framing`) and fitted to the keypoint models' points. The keypoint
    /// models load when the photo needs them: to fit, to mask a photo without alpha, and for
    /// the points the viewer shows over a given view; where only the mask needs them and they
    /// do not load, the report says so and the mask is left to the caller.
    pub fn source(
        &mut self,
        body: BodyRef,
        photo: Photo,
        tracked: Tracked,
        framing: Framing,
        progress: &mut dyn FnMut(Stage) -> bool,
    ) -> Result<Source, ReconstructError> {
        let file = photo.name();
        let mut clock = StageClock::default();
        let mut report = Report::default();
        let (given, ehm_identity) = match tracked {
            Tracked::File(path) => {
                let name = path.display().to_string();
                let tracking = Tracking::load(&path)?;
                let view = match body {
                    BodyRef::Template(b) => SourceView::from_tracking(&tracking, b, &name)?,
                    BodyRef::Ehm(b) => SourceView::from_tracking(&tracking, b, &name)?,
                };
                // The tracker's skeleton (joint offsets, head and hand scale) is this person's.
                let identity = tracking
                    .identity
                    .ehm
                    .as_ref()
                    .map(EhmIdentityRecord::to_identity);
                (Some((view, false)), identity)
            }
            Tracked::Given(view) => (Some((view, true)), None),
            Tracked::Fit => (None, None),
        };
        // A given view of a photo file also gets the pose model's points, to show over it.
        let points =
            given.as_ref().is_some_and(|(_, points)| *points) && matches!(photo, Photo::File(_));
        let (pixels, has_alpha) = photo.decode()?;
        let fitting = given.is_none();
        let models = if fitting || points || !has_alpha {
            clock.start(Stage::LoadModels, progress)?;
            match self.keypoints.load() {
                Ok(models) => Some(models),
                Err(e) if fitting => {
                    return Err(PhotoError {
                        file,
                        problem: format!(
                            "has no tracking file, and fitting it needs the keypoint models: {e}"
                        ),
                    }
                    .into());
                }
                Err(e) => {
                    report
                        .notes
                        .push(format!("the keypoint models did not load: {e}"));
                    None
                }
            }
        } else {
            None
        };
        report.body_points = models.as_ref().map(|m| m.body_points());
        clock.start(Stage::Keypoints, progress)?;
        let square = match &given {
            Some((view, _)) => Square::Tracked {
                crop: view.crop,
                points,
            },
            None => Square::Fitted(framing),
        };
        let (read, models) = match models {
            Some(models) => {
                let read = SourcePhoto::from_pixels(
                    pixels,
                    has_alpha,
                    &file,
                    square,
                    Some(&mut *models),
                    progress,
                )?;
                (read, Some(models))
            }
            None => (
                SourcePhoto::from_pixels(pixels, has_alpha, &file, square, None, progress)?,
                None,
            ),
        };
        let view = match given {
            Some((view, _)) => view,
            None => {
                clock.start(Stage::Fit, progress)?;
                let found = read
                    .detections
                    .as_ref()
                    .expect("a fitted photo's keypoints");
                let face = &mut models.expect("a fit loads the models").face;
                let (mut view, fit) = match body {
                    BodyRef::Template(b) => fit_detections(b, found, face, SOURCE_SIZE),
                    BodyRef::Ehm(b) => fit_ehm_detections(b, found, face, SOURCE_SIZE),
                }
                .map_err(|e| fit_error(&file, e))?;
                view.crop = read.crop;
                // The default body's outline to the person mask (GUAVA's networks learned their
                // own offsets from EHM-Tracker's fits, which use no silhouette).
                let mask = match (&read.image.mask, &read.detections) {
                    (Some(alpha), _) => Some(alpha.clone()),
                    (None, Some(d)) => Some(d.person_mask(read.image.size as usize)),
                    (None, None) => None,
                };
                if let (BodyRef::Template(b), Some(mask)) = (body, mask) {
                    clock.start(Stage::Silhouette, progress)?;
                    let (fitted, silhouette) =
                        fit_silhouette(b, &view, &fit, &mask, read.image.size);
                    view = fitted;
                    report.silhouette = Some(silhouette);
                }
                report.fit = Some(fit);
                view
            }
        };
        report.crop = read.crop;
        report.mask = if has_alpha {
            MaskSource::Alpha
        } else if read.detections.is_some() {
            MaskSource::Segmentation
        } else {
            MaskSource::Silhouette
        };
        report.keypoints = read
            .detections
            .as_ref()
            .map(|d| d.pose.keypoints.clone())
            .unwrap_or_default();
        if let Some(people) = read.detections.as_ref().map(|d| d.pose.people)
            && people > 1
        {
            report.notes.push(format!(
                "{people} people on the photo: the avatar is of the one nearest its centre \
                 (crop the photo to choose another)"
            ));
        }
        report.timings = clock.finish();
        Ok(Source {
            photo: read,
            view,
            ehm_identity,
            report,
        })
    }

    /// Makes an avatar of `photo` in `mode`: [`Self::source`], then the reconstruction. Every
    /// error names the file it is about.
    pub fn reconstruct(
        &mut self,
        mode: Mode,
        photo: Photo,
        tracked: Tracked,
        progress: &mut dyn FnMut(Stage) -> bool,
    ) -> Result<Outcome, ReconstructError> {
        let (file, source_name) = (photo.name(), photo.source_name());
        // GUAVA's networks learned from EHM-Tracker's crops around the person.
        let framing = match mode {
            Mode::Default(_) => Framing::KeepCentred,
            Mode::Guava { .. } => Framing::AroundPerson,
        };
        let source = self.source(mode.fit_body(), photo, tracked, framing, progress)?;
        let Source {
            photo: read,
            view,
            ehm_identity,
            mut report,
        } = source;
        let segmentation = read.detections.as_ref();
        let photo = with_person_mask(read.image, read.detections.as_ref());
        let (avatar, core) = match mode {
            Mode::Default(body) => {
                let size = self.uv_size;
                let uv = self.uv_map(body.name(), body.vertex_count(), size, || {
                    UvMap::for_body(body, size)
                });
                reconstruct_default(body, &uv, &view, photo.clone(), &source_name, progress)?
            }
            Mode::Guava { body, networks } => {
                report.networks = Some(networks.source.clone());
                let size = networks.dims.uv as u32;
                let uv = self.uv_map(body.name(), body.vertex_count(), size, || {
                    uv_map(body, size)
                });
                // The encoder sees the photo at its own size.
                let side = networks.dims.image as u32;
                let mut image = SourceImage::from_rgba_at(
                    &read.pixels,
                    read.crop,
                    read.has_alpha,
                    &file,
                    side,
                )?;
                if image.mask.is_none() {
                    let found = segmentation.ok_or_else(|| PhotoError {
                        file: file.clone(),
                        problem: "has no alpha channel, and its person mask needs the pose \
                                  model, which did not load"
                            .into(),
                    })?;
                    image.apply_mask(found.person_mask(image.size as usize));
                }
                match ehm_identity.filter(|identity| *identity != body.identity) {
                    Some(identity) => {
                        let mut tracked = body.clone();
                        tracked.identity = identity;
                        reconstruct_guava(
                            networks,
                            &tracked,
                            &uv,
                            &view,
                            &image,
                            &source_name,
                            progress,
                        )?
                    }
                    None => reconstruct_guava(
                        networks,
                        body,
                        &uv,
                        &view,
                        &image,
                        &source_name,
                        progress,
                    )?,
                }
            }
        };
        report.add(core);
        Ok(Outcome {
            avatar,
            view,
            photo,
            report,
        })
    }

    /// The UV map of a body at `size`², made by `make` when the last one was another's.
    fn uv_map(
        &mut self,
        body: &str,
        vertices: usize,
        size: u32,
        make: impl FnOnce() -> UvMap,
    ) -> Arc<UvMap> {
        let key = UvKey {
            body: body.into(),
            vertices,
            size,
        };
        match &self.uv {
            Some((k, uv)) if *k == key => uv.clone(),
            _ => {
                let uv = Arc::new(make());
                self.uv = Some((key, uv.clone()));
                uv
            }
        }
    }

    /// `photo` as `view` sees it, at [`SOURCE_SIZE`]: its square, masked by its alpha or else by
    /// the keypoint models' person mask (what an avatar made from it is compared with).
    pub fn masked_photo(
        &mut self,
        photo: Photo,
        view: &SourceView,
        progress: &mut dyn FnMut(Stage) -> bool,
    ) -> Result<SourceImage, ReconstructError> {
        let file = photo.name();
        let (pixels, has_alpha) = photo.decode()?;
        let square = Square::Tracked {
            crop: view.crop,
            points: false,
        };
        let models = if has_alpha {
            None
        } else {
            Some(self.keypoints.load().map_err(|e| PhotoError {
                file: file.clone(),
                problem: format!(
                    "has no alpha channel, and its person mask needs the pose model: {e}"
                ),
            })?)
        };
        let read = SourcePhoto::from_pixels(pixels, has_alpha, &file, square, models, progress)?;
        Ok(with_person_mask(read.image, read.detections.as_ref()))
    }

    /// The keypoint models, loaded (for callers that run them without reconstructing).
    pub fn landmarkers(&mut self) -> Result<&mut Landmarkers, String> {
        self.keypoints.load()
    }
}

/// A failed fit of the photo `file`.
fn fit_error(file: &str, e: FitError) -> ReconstructError {
    PhotoError {
        file: file.into(),
        problem: match e {
            FitError::NoPerson { .. } => format!("{e}; give the photo's tracking file"),
            e => e.to_string(),
        },
    }
    .into()
}
