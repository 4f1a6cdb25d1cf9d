//! The refiner pass: the splatting pass's feature image turned into the final picture by a
//! convolutional network. Two kinds, told apart by the model file:
//! - the default mode's refiner (`assets/refiner/default_refiner.onnx`, trained by
//!   `tools/train_refiner.py` on `eval::pairs`) reads RGB, the source-confidence channel and alpha at
//!   any size, and gives RGB and alpha (premultiplied, on black), so it can also clean the
//!   silhouette (held within a pixel of the splat's: [`REACH_PX`]);
//! - GUAVA's StyleUNet (`guava_refiner.onnx` from `tools/export_guava_onnx.py`) reads all of the
//!   avatar's channels at its fixed square side (512²) and gives RGB on black (trained so: GUAVA
//!   renders on a black background); the splat's alpha composites it. Other frame sizes are
//!   letterboxed into its square and resampled (bilinear) there and back.
//!
//! Either runs through ONNX Runtime on the CPU (the splat image read back, refined and
//! composited) or, where its operators allow, through our own compute passes on the splatting
//! device ([`wgsl`]); [`RefinerOn`] chooses.

pub mod wgsl;

use std::path::{Path, PathBuf};

use crate::avatar::AvatarKind;
use crate::gpu::GpuContext;
use crate::guava_mode::models::{REFINER_FILE, REFINER_ROLE};
use crate::onnx::{OnnxError, OnnxRuntime, Session, TensorF32};
use crate::onnx_model::Model;
use crate::render::SplatImage;

/// The default refiner, shipped in the repository.
pub const DEFAULT_REFINER: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/refiner/default_refiner.onnx"
);

/// The default refiner's input: [1, 5, H, W] — R, G, B, source confidence, alpha.
pub const INPUT: &str = "splat";
/// Its output: [1, 4, H, W] — R, G, B (premultiplied), alpha.
pub const OUTPUT: &str = "refined";
pub const INPUT_CHANNELS: usize = 5;
pub const OUTPUT_CHANNELS: usize = 4;
/// Sides are padded to a multiple of this (the network halves the image twice).
pub const MULTIPLE: u32 = 4;
/// GUAVA's refiner's output: [1, 3, S, S], RGB in [0, 1] on black (its input is [`INPUT`]).
pub const GUAVA_OUTPUT: &str = "rgb";

#[derive(Debug, thiserror::Error)]
pub enum RefineError {
    #[error(transparent)]
    Onnx(#[from] OnnxError),
    #[error("{path}: {problem}")]
    Model { path: PathBuf, problem: String },
    #[error("{path}: the refiner reads {wanted}; this image has {channels} channels")]
    Channels {
        path: PathBuf,
        wanted: String,
        channels: usize,
    },
}

/// Which network, and what it reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RefinerKind {
    /// The default mode's: RGB, confidence, alpha at any size.
    Default,
    /// GUAVA's StyleUNet: `channels` feature channels at `side`².
    Guava { channels: usize, side: usize },
}

/// Where a refiner's network runs.
enum Engine {
    /// ONNX Runtime on the CPU (any model ONNX Runtime takes): the splat image is read back.
    OnnxRuntime(Session),
    /// Our own compute passes on a wgpu device ([`wgsl`]; the operators a small U-Net uses):
    /// on the splatting device the splat layers are read where they lie.
    Wgsl(Box<wgsl::WgslNetwork>),
}

/// Where the user wants the refiner to run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum RefinerOn {
    /// Our WGSL passes on a hardware adapter, ONNX Runtime on a software one (lavapipe, where
    /// `guava bench refiner` measured ONNX Runtime two orders of magnitude faster) or where the
    /// model has an operator the passes do not run (GUAVA's StyleUNet).
    #[default]
    Auto,
    /// ONNX Runtime on the CPU.
    Cpu,
    /// Our WGSL passes on the splatting device.
    Gpu,
}

impl RefinerOn {
    pub const ALL: [Self; 3] = [Self::Auto, Self::Cpu, Self::Gpu];

    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Cpu => "CPU (ONNX Runtime)",
            Self::Gpu => "GPU (WGSL passes)",
        }
    }
}

/// A refiner slot shared by whoever loads it and whoever runs it (a viewer's view, its
/// workers and exports): empty until loaded.
pub type SharedRefiner = std::sync::Arc<std::sync::Mutex<Option<Refiner>>>;

/// A loaded refiner network.
pub struct Refiner {
    engine: Engine,
    pub kind: RefinerKind,
    pub path: PathBuf,
    /// Where it was asked to run ([`Refiner::load_on`]; `Cpu` or `Gpu` by the other loaders).
    pub on: RefinerOn,
    /// What the model file says it is, for the UI and reports.
    pub description: String,
}

/// What a model file declares: its input's and output's dims (-1 where free) and metadata.
struct Signature {
    input: Option<Vec<i64>>,
    /// `OUTPUT`'s or `GUAVA_OUTPUT`'s dims, as the role says.
    output: Option<Vec<i64>>,
    role: Option<String>,
    source: Option<String>,
    description: Option<String>,
}

impl Refiner {
    /// Loads and checks the model at `path` where `on` says, the WGSL passes on `gpu`'s device.
    /// `Auto` falls back to ONNX Runtime where the passes do not run the model.
    pub fn load_on(on: RefinerOn, gpu: &GpuContext, path: &Path) -> Result<Self, RefineError> {
        let software = gpu.adapter.get_info().device_type == wgpu::DeviceType::Cpu;
        let mut refiner = match on {
            RefinerOn::Cpu => Self::load(OnnxRuntime::load()?, path),
            RefinerOn::Gpu => Self::load_wgsl(gpu, path),
            RefinerOn::Auto if software => Self::load(OnnxRuntime::load()?, path),
            RefinerOn::Auto => Self::load_wgsl(gpu, path).or_else(|e| {
                log::info!("{e}; running it with ONNX Runtime instead");
                Self::load(OnnxRuntime::load()?, path)
            }),
        }?;
        refiner.on = on;
        Ok(refiner)
    }

    /// Loads and checks the model at `path` for ONNX Runtime: GUAVA's if the exporter marked
    /// it so, else the default kind.
    pub fn load(runtime: &OnnxRuntime, path: &Path) -> Result<Self, RefineError> {
        let session = runtime.session(path)?;
        let shape = |shapes: Vec<(String, Vec<i64>)>, name: &str| {
            shapes.into_iter().find(|(n, _)| n == name).map(|(_, s)| s)
        };
        let role = session.metadata("guava_rs.role");
        let output_name = output_name(role.as_deref());
        let signature = Signature {
            input: shape(session.input_shapes(), INPUT),
            output: shape(session.output_shapes(), output_name),
            source: session.metadata("guava_rs.source"),
            description: session.metadata("description"),
            role,
        };
        Self::checked(Engine::OnnxRuntime(session), path, signature)
    }

    /// Loads and checks the model at `path` for our own compute passes on `gpu`'s device; an
    /// operator they do not run is an error naming it (run that model with [`Refiner::load`]).
    pub fn load_wgsl(gpu: &GpuContext, path: &Path) -> Result<Self, RefineError> {
        let problem = |problem: String| RefineError::Model {
            path: path.to_path_buf(),
            problem,
        };
        let model = Model::read(path).map_err(|e| problem(e.problem))?;
        let dims = |name: &str| {
            let info = model.value_info(name)?;
            Some(info.dims.iter().map(|d| d.unwrap_or(-1)).collect())
        };
        let role = model.metadata.get("guava_rs.role").cloned();
        let signature = Signature {
            input: dims(INPUT),
            output: dims(output_name(role.as_deref())),
            source: model.metadata.get("guava_rs.source").cloned(),
            description: model.metadata.get("description").cloned(),
            role,
        };
        let network = wgsl::WgslNetwork::compile(gpu, &model).map_err(problem)?;
        Self::checked(Engine::Wgsl(Box::new(network)), path, signature)
    }

    fn checked(engine: Engine, path: &Path, signature: Signature) -> Result<Self, RefineError> {
        let problem = |problem: String| RefineError::Model {
            path: path.to_path_buf(),
            problem,
        };
        let Signature {
            input,
            output,
            role,
            source,
            description,
        } = signature;
        let (kind, description) = if role.as_deref() == Some(REFINER_ROLE) {
            let kind = match (input.as_deref(), output.as_deref()) {
                (Some(&[1, c, h, w]), Some(&[1, 3, oh, ow]))
                    if c >= 3 && h > 0 && h == w && (oh, ow) == (h, w) =>
                {
                    RefinerKind::Guava {
                        channels: c as usize,
                        side: h as usize,
                    }
                }
                (i, o) => {
                    return Err(problem(format!(
                        "GUAVA's refiner should read `{INPUT}` [1, C, S, S] and give \
                         `{GUAVA_OUTPUT}` [1, 3, S, S] (fixed S); it declares {i:?} and {o:?}"
                    )));
                }
            };
            let source = source.unwrap_or_else(|| "unknown weights".into());
            (kind, format!("GUAVA's refiner ({source})"))
        } else {
            let channels = |s: &Option<Vec<i64>>| s.as_ref().and_then(|s| s.get(1).copied());
            match channels(&input) {
                Some(c) if c == INPUT_CHANNELS as i64 => {}
                other => {
                    return Err(problem(format!(
                        "input `{INPUT}` should have {INPUT_CHANNELS} channels, has {other:?}"
                    )));
                }
            }
            match channels(&output) {
                Some(c) if c == OUTPUT_CHANNELS as i64 => {}
                other => {
                    return Err(problem(format!(
                        "output `{OUTPUT}` should have {OUTPUT_CHANNELS} channels, has {other:?}"
                    )));
                }
            }
            let description = description.unwrap_or_else(|| "refiner".into());
            (RefinerKind::Default, description)
        };
        let on = match engine {
            Engine::OnnxRuntime(_) => RefinerOn::Cpu,
            Engine::Wgsl(_) => RefinerOn::Gpu,
        };
        Ok(Self {
            engine,
            kind,
            path: path.to_path_buf(),
            on,
            description,
        })
    }

    /// Where it runs, for the UI and reports: ONNX Runtime with the providers that actually
    /// registered (and any asked for that did not), or our WGSL passes.
    pub fn engine_name(&self) -> &str {
        match &self.engine {
            Engine::OnnxRuntime(session) => &session.engine,
            Engine::Wgsl(_) => "WGSL compute passes",
        }
    }

    /// The network on `input` ([1, C, H, W]): its output, [1, `out_c`, H, W] flat (checked).
    fn run(
        &mut self,
        input: Vec<f32>,
        [c, h, w]: [usize; 3],
        out_c: usize,
    ) -> Result<Vec<f32>, RefineError> {
        let out = self.run_unchecked(input, [c, h, w])?;
        if out.len() != out_c * h * w {
            return Err(RefineError::Model {
                path: self.path.clone(),
                problem: format!(
                    "gives {} values for a [1, {c}, {h}, {w}] input, not [1, {out_c}, {h}, {w}]",
                    out.len()
                ),
            });
        }
        Ok(out)
    }

    fn run_unchecked(
        &mut self,
        input: Vec<f32>,
        [c, h, w]: [usize; 3],
    ) -> Result<Vec<f32>, RefineError> {
        match &mut self.engine {
            Engine::OnnxRuntime(session) => {
                let outputs = session.run(vec![(
                    INPUT,
                    TensorF32 {
                        shape: vec![1, c, h, w],
                        data: input,
                    },
                )])?;
                Ok(outputs
                    .into_iter()
                    .next()
                    .map(|t| t.data)
                    .unwrap_or_default())
            }
            Engine::Wgsl(network) => network
                .run_tensor(&input, h as u32, w as u32)
                .map(|(out, _)| out)
                .map_err(|problem| RefineError::Model {
                    path: self.path.clone(),
                    problem,
                }),
        }
    }

    /// The image `renderer` just drew (`HeadlessRenderer::draw`) refined. The WGSL engine on the
    /// renderer's device gathers a default refiner's input from the splat layers where they lie
    /// and reads back only its output; otherwise the splat image is read back and refined.
    pub fn refine_drawn(
        &mut self,
        renderer: &crate::render::HeadlessRenderer,
    ) -> Result<SplatImage, RefineError> {
        let (device, queue) = (&renderer.gpu.device, &renderer.gpu.queue);
        let splatter = &renderer.splatter;
        let mut encoder = device.create_command_encoder(&Default::default());
        let Some([width, height]) = self.encode_splat(&mut encoder, device, splatter)? else {
            let image = splatter
                .read_image(device, queue)
                .unwrap_or_else(|| SplatImage::new(1, 1, 0));
            return self.refine(&image);
        };
        let Engine::Wgsl(network) = &mut self.engine else {
            unreachable!("encoded by the WGSL engine");
        };
        let (out, c) = network.finish(encoder);
        let padded = [padded(width), padded(height)];
        if out.len() != OUTPUT_CHANNELS * padded[0] * padded[1] {
            return Err(RefineError::Model {
                path: self.path.clone(),
                problem: format!(
                    "gives [1, {c}, ..] for a {}×{} input, not [1, {OUTPUT_CHANNELS}, {}, {}]",
                    padded[0], padded[1], padded[1], padded[0]
                ),
            });
        }
        let mut refined = unpad_default(&out, width, height);
        if let Some([alpha, inv_depth]) = splatter.read_aux(device, queue) {
            hold_within_splat(&mut refined, &alpha);
            refined.inv_depth = inv_depth;
        }
        Ok(refined)
    }

    /// Records the refiner on `splatter`'s output into `encoder`, its premultiplied RGB and
    /// alpha written into `target` (rgba32float, the image's size) — where it runs on `device`
    /// as our WGSL passes reading the splat layers where they lie (a default refiner): a pass on
    /// a view's frame. `Ok(false)` where it does not: refine a readback of the image then.
    pub fn encode_into(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        device: &wgpu::Device,
        splatter: &crate::render::Splatter,
        target: &wgpu::Texture,
    ) -> Result<bool, RefineError> {
        if self.encode_splat(encoder, device, splatter)?.is_none() {
            return Ok(false);
        }
        let Engine::Wgsl(network) = &self.engine else {
            unreachable!("encoded by the WGSL engine");
        };
        let aux = splatter.aux().expect("encoded from the splat's layers");
        network
            .encode_rgba(encoder, aux, target)
            .map_err(|problem| RefineError::Model {
                path: self.path.clone(),
                problem,
            })?;
        Ok(true)
    }

    /// Whether this refiner runs on `device` as our WGSL passes reading a default-mode splat
    /// where it lies ([`Self::encode_into`]).
    pub fn runs_on(&self, device: &wgpu::Device) -> bool {
        matches!((&self.engine, self.kind),
            (Engine::Wgsl(network), RefinerKind::Default) if network.device() == device)
    }

    /// Records the network on `splatter`'s output where [`Self::runs_on`] its device; returns
    /// the image's size then, `None` otherwise.
    fn encode_splat(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        device: &wgpu::Device,
        splatter: &crate::render::Splatter,
    ) -> Result<Option<[u32; 2]>, RefineError> {
        if !self.runs_on(device) {
            return Ok(None);
        }
        let (Engine::Wgsl(network), Some(features), Some(aux)) =
            (&mut self.engine, splatter.features(), splatter.aux())
        else {
            return Ok(None);
        };
        let channels = splatter.channels().unwrap_or(0) as usize;
        if channels < 4 {
            return Err(RefineError::Channels {
                path: self.path.clone(),
                wanted: DEFAULT_WANTS.into(),
                channels,
            });
        }
        let (width, height) = (features.width(), features.height());
        let layers = [0, 1, 2, 3].map(wgsl::Layer::Feature);
        let layers = [&layers[..], &[wgsl::Layer::Alpha]].concat();
        let padded = [padded(width) as u32, padded(height) as u32];
        network
            .encode_splat(encoder, features, aux, &layers, [width, height], padded)
            .map_err(|problem| RefineError::Model {
                path: self.path.clone(),
                problem,
            })?;
        Ok(Some([width, height]))
    }

    /// `image` (rendered on black) refined: RGB premultiplied and alpha; its depth is kept.
    pub fn refine(&mut self, image: &SplatImage) -> Result<SplatImage, RefineError> {
        let wrong = |wanted: String| RefineError::Channels {
            path: self.path.clone(),
            wanted,
            channels: image.channels,
        };
        let mut refined = match self.kind {
            RefinerKind::Default if image.channels < 4 => {
                return Err(wrong(DEFAULT_WANTS.into()));
            }
            RefinerKind::Guava { channels, .. } if image.channels != channels => {
                return Err(wrong(format!(
                    "{channels} channels (an avatar from the same GUAVA networks)"
                )));
            }
            RefinerKind::Default => self.refine_default(image)?,
            RefinerKind::Guava { side, .. } => self.refine_guava(image, side)?,
        };
        refined.inv_depth.clone_from(&image.inv_depth);
        Ok(refined)
    }

    fn refine_default(&mut self, image: &SplatImage) -> Result<SplatImage, RefineError> {
        let (w, h) = (image.width as usize, image.height as usize);
        let (pw, ph) = (padded(image.width), padded(image.height));
        let mut input = vec![0.0f32; INPUT_CHANNELS * pw * ph];
        let planes = [
            image.plane(0),
            image.plane(1),
            image.plane(2),
            image.plane(3),
            &image.alpha,
        ];
        for (c, plane) in planes.iter().enumerate() {
            for y in 0..h {
                let row = &plane[y * w..(y + 1) * w];
                let at = (c * ph + y) * pw;
                input[at..at + w].copy_from_slice(row);
            }
        }
        let out = self.run(input, [INPUT_CHANNELS, ph, pw], OUTPUT_CHANNELS)?;
        let mut refined = unpad_default(&out, image.width, image.height);
        hold_within_splat(&mut refined, &image.alpha);
        Ok(refined)
    }

    fn refine_guava(&mut self, image: &SplatImage, side: usize) -> Result<SplatImage, RefineError> {
        let (w, h) = (image.width as usize, image.height as usize);
        let square = Letterbox::new(w, h, side);
        let mut input = Vec::with_capacity(image.channels * side * side);
        for c in 0..image.channels {
            square.sample_square(image.plane(c), &mut input);
        }
        let out = self.run(input, [image.channels, side, side], 3)?;
        let mut refined = SplatImage::new(image.width, image.height, 3);
        refined.features.clear();
        for c in 0..3 {
            square.sample_frame(
                &out[c * side * side..(c + 1) * side * side],
                &mut refined.features,
            );
        }
        refined.alpha.clone_from(&image.alpha);
        Ok(refined)
    }
}

const DEFAULT_WANTS: &str = "RGB and the source-confidence channel (a default-mode avatar)";

/// How far (pixels) the default refiner's picture may reach past the splat's: its alpha is held
/// under the splat's highest within this many pixels, so it recolours and cleans the silhouette
/// but grows it by a pixel at most. Unheld, trained on synthetic subjects whose hair the front
/// photo shows as a fringe, it painted a dark arc of hair over real heads seen from behind; held,
/// it also scores better on unseen bodies and the same on the held-out pairs (docs/refiner.md).
/// The on-device pass holds its output the same way (`to_rgba` in shaders/refine.wgsl, given
/// this as `kind`).
pub const REACH_PX: usize = 1;

/// Holds `refined` (premultiplied RGB and alpha) within `splat`, the splat's alpha (the same
/// size) dilated by [`REACH_PX`]: where the refined alpha is higher, it and its RGB are scaled
/// down to that.
pub fn hold_within_splat(refined: &mut SplatImage, splat: &[f32]) {
    let (w, h) = (refined.width as usize, refined.height as usize);
    let plane = w * h;
    for y in 0..h {
        for x in 0..w {
            let mut reach = 0.0f32;
            for yy in y.saturating_sub(REACH_PX)..(y + REACH_PX + 1).min(h) {
                for xx in x.saturating_sub(REACH_PX)..(x + REACH_PX + 1).min(w) {
                    reach = reach.max(splat[yy * w + xx]);
                }
            }
            let i = y * w + x;
            let alpha = refined.alpha[i];
            if alpha > reach {
                let scale = reach / alpha;
                refined.alpha[i] = reach;
                for c in 0..3 {
                    refined.features[c * plane + i] *= scale;
                }
            }
        }
    }
}

/// The default refiner's output ([4, padded H, padded W]) cropped to `width`×`height`: RGB
/// and alpha.
fn unpad_default(out: &[f32], width: u32, height: u32) -> SplatImage {
    let (w, h) = (width as usize, height as usize);
    let (pw, ph) = (padded(width), padded(height));
    let mut refined = SplatImage::new(width, height, 3);
    for c in 0..OUTPUT_CHANNELS {
        let target = match c {
            3 => &mut refined.alpha[..],
            _ => &mut refined.features[c * w * h..(c + 1) * w * h],
        };
        for y in 0..h {
            let at = (c * ph + y) * pw;
            target[y * w..(y + 1) * w].copy_from_slice(&out[at..at + w]);
        }
    }
    refined
}

/// The output `Refiner::load` or `load_wgsl` checks, by the model's role.
fn output_name(role: Option<&str>) -> &'static str {
    if role == Some(REFINER_ROLE) {
        GUAVA_OUTPUT
    } else {
        OUTPUT
    }
}

/// The refiner an avatar is refined by: the default one for default reconstructions, GUAVA's
/// from the networks folder it was made with for GUAVA-mode avatars.
pub fn refiner_for(kind: AvatarKind, networks: Option<&Path>) -> Result<PathBuf, String> {
    match (kind, networks) {
        (AvatarKind::DefaultReconstruction, _) => Ok(PathBuf::from(DEFAULT_REFINER)),
        (AvatarKind::Guava, Some(dir)) => Ok(dir.join(REFINER_FILE)),
        (AvatarKind::Guava, None) => Err(
            "a GUAVA-mode avatar is refined by GUAVA's refiner: give the networks folder it was \
             reconstructed with"
                .into(),
        ),
    }
}

fn padded(side: u32) -> usize {
    side.div_ceil(MULTIPLE) as usize * MULTIPLE as usize
}

/// A `w`×`h` frame centred in a square of side max(w, h), which maps onto `side`² (the same
/// frame at GUAVA's size needs no resampling).
struct Letterbox {
    w: usize,
    h: usize,
    side: usize,
    /// Frame pixels per square pixel, and the frame's offset in the square (frame pixels).
    scale: f32,
    offset: [f32; 2],
}

impl Letterbox {
    fn new(w: usize, h: usize, side: usize) -> Self {
        let m = w.max(h);
        Self {
            w,
            h,
            side,
            scale: m as f32 / side as f32,
            offset: [(m - w) as f32 / 2.0, (m - h) as f32 / 2.0],
        }
    }

    /// Appends `plane` (the frame's) resampled into the square; outside the frame is black.
    fn sample_square(&self, plane: &[f32], out: &mut Vec<f32>) {
        for v in 0..self.side {
            for u in 0..self.side {
                let x = (u as f32 + 0.5) * self.scale - 0.5 - self.offset[0];
                let y = (v as f32 + 0.5) * self.scale - 0.5 - self.offset[1];
                out.push(bilinear(plane, self.w, self.h, x, y));
            }
        }
    }

    /// Appends `square` (side²) resampled back onto the frame.
    fn sample_frame(&self, square: &[f32], out: &mut Vec<f32>) {
        for y in 0..self.h {
            for x in 0..self.w {
                let u = (x as f32 + self.offset[0] + 0.5) / self.scale - 0.5;
                let v = (y as f32 + self.offset[1] + 0.5) / self.scale - 0.5;
                let clamp = |t: f32| t.clamp(0.0, (self.side - 1) as f32);
                out.push(bilinear(square, self.side, self.side, clamp(u), clamp(v)));
            }
        }
    }
}

/// `plane` (w×h) at (x, y) in pixel-centre coordinates, bilinear; zero outside.
fn bilinear(plane: &[f32], w: usize, h: usize, x: f32, y: f32) -> f32 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let at = |xi: f32, yi: f32| {
        if xi < 0.0 || yi < 0.0 || xi >= w as f32 || yi >= h as f32 {
            0.0
        } else {
            plane[yi as usize * w + xi as usize]
        }
    };
    let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1.0, y0) * fx;
    let bottom = at(x0, y0 + 1.0) * (1.0 - fx) + at(x0 + 1.0, y0 + 1.0) * fx;
    top * (1.0 - fy) + bottom * fy
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize) -> Vec<f32> {
        (0..w * h)
            .map(|i| (i % w) as f32 * 0.01 + (i / w) as f32 * 0.02)
            .collect()
    }

    /// A splat of one opaque pixel: the refined picture keeps its alpha within a pixel of it
    /// (scaling RGB with it) and nothing beyond; what is already under the reach is untouched.
    #[test]
    fn the_refined_picture_is_held_within_a_pixel_of_the_splat() {
        let (w, h) = (5, 5);
        let mut splat = vec![0.0; w * h];
        splat[2 * w + 2] = 0.8;
        let mut refined = SplatImage::new(w as u32, h as u32, 3);
        refined.alpha.fill(1.0);
        refined.features.fill(0.5);
        refined.alpha[0] = 0.0;
        hold_within_splat(&mut refined, &splat);
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let near = x.abs_diff(2) <= REACH_PX && y.abs_diff(2) <= REACH_PX;
                let alpha = if near { 0.8 } else { 0.0 };
                assert_eq!(refined.alpha[i], if i == 0 { 0.0 } else { alpha });
                for c in 0..3 {
                    let rgb = refined.features[c * w * h + i];
                    assert!((rgb - if i == 0 { 0.5 } else { 0.5 * alpha }).abs() < 1e-6);
                }
            }
        }
    }

    #[test]
    fn a_frame_at_the_refiners_side_passes_unchanged() {
        let plane = ramp(16, 16);
        let square = Letterbox::new(16, 16, 16);
        let (mut there, mut back) = (Vec::new(), Vec::new());
        square.sample_square(&plane, &mut there);
        square.sample_frame(&there, &mut back);
        assert_eq!(there, plane);
        assert_eq!(back, plane);
    }

    #[test]
    fn a_wide_frame_is_centred_in_the_square_and_comes_back() {
        // 32×16 into 16²: half scale, rows 4..12 of the square hold the frame, black around it.
        let (w, h) = (32, 16);
        let plane = ramp(w, h);
        let square = Letterbox::new(w, h, 16);
        let mut there = Vec::new();
        square.sample_square(&plane, &mut there);
        assert!(there[..16 * 3].iter().all(|&v| v == 0.0), "black above");
        assert!(there[16 * 13..].iter().all(|&v| v == 0.0), "black below");
        let mut back = Vec::new();
        square.sample_frame(&there, &mut back);
        // A linear ramp survives bilinear down- and upsampling away from the frame's border.
        for y in 2..h - 2 {
            for x in 2..w - 2 {
                let (got, want) = (back[y * w + x], plane[y * w + x]);
                assert!((got - want).abs() < 1e-4, "({x}, {y}): {got} vs {want}");
            }
        }
    }
}
