//! GUAVA's networks as the four ONNX models `tools/export_guava_onnx.py` writes, loaded from a
//! folder the user picks and checked against one interface before anything runs: every file
//! present, written by this exporter version, and its inputs and outputs of the shapes the others
//! agree on. The refiner is only checked here; [`crate::refine::Refiner`] runs it per frame. Sizes are read from the models (GUAVA's: a 518² image, 512² features and UV map,
//! 32 channels), so the reduced test models run through the same code.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::onnx::{OnnxError, OnnxRuntime, Session, TensorF32};

/// The exporter's format; a model with another is refused (re-export it).
pub const FORMAT: &str = "1";

/// The four models, by role, and their file names in the folder.
pub const FILES: [(Role, &str); 4] = [
    (Role::Encoder, "guava_encoder.onnx"),
    (Role::VertexDecoder, "guava_vertex_decoder.onnx"),
    (Role::UvDecoder, "guava_uv_decoder.onnx"),
    (Role::Refiner, REFINER_FILE),
];

/// GUAVA's refiner (its StyleUNet: the splat image's channels → RGB) in the folder.
pub const REFINER_FILE: &str = "guava_refiner.onnx";
/// The `guava_rs.role` the exporter gives the refiner.
pub const REFINER_ROLE: &str = "refiner";

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Role {
    Encoder,
    VertexDecoder,
    UvDecoder,
    Refiner,
}

impl Role {
    /// The `guava_rs.role` metadata value the exporter writes.
    fn key(self) -> &'static str {
        match self {
            Role::Encoder => "encoder",
            Role::VertexDecoder => "vertex_decoder",
            Role::UvDecoder => "uv_decoder",
            Role::Refiner => REFINER_ROLE,
        }
    }

    fn file(self) -> &'static str {
        FILES
            .iter()
            .find(|(r, _)| *r == self)
            .expect("every role")
            .1
    }
}

/// One dimension of the interface: a fixed size, or a size named by a letter that must agree
/// wherever it appears.
#[derive(Clone, Copy)]
enum Dim {
    Is(i64),
    Named(char),
}
use Dim::{Is, Named};

type Tensors = &'static [(&'static str, &'static [Dim])];

/// Inputs and outputs per role. S image side, R feature side, U UV side, X pixel-feature
/// channels (RGB ‖ f_map1), P vertex-feature channels, G vertex global, E UV style, N vertices,
/// C Gaussian channels.
fn interface(role: Role) -> (Tensors, Tensors) {
    match role {
        Role::Encoder => (
            &[("image", &[Is(1), Is(3), Named('S'), Named('S')])],
            &[
                (
                    "pixel_features",
                    &[Is(1), Named('X'), Named('R'), Named('R')],
                ),
                (
                    "vertex_features",
                    &[Is(1), Named('P'), Named('R'), Named('R')],
                ),
                ("vertex_global", &[Is(1), Named('G')]),
                ("uv_style", &[Is(1), Named('E')]),
            ],
        ),
        Role::VertexDecoder => (
            &[
                ("sampled", &[Is(1), Named('N'), Named('P')]),
                ("vertex_global", &[Is(1), Named('G')]),
                ("cam_dir", &[Is(1), Is(3)]),
            ],
            &[
                ("colors", &[Is(1), Named('N'), Named('C')]),
                ("opacities", &[Is(1), Named('N'), Is(1)]),
                ("scales", &[Is(1), Named('N'), Is(3)]),
                ("rotations", &[Is(1), Named('N'), Is(4)]),
            ],
        ),
        Role::UvDecoder => (
            &[
                ("uv_features", &[Is(1), Named('X'), Named('U'), Named('U')]),
                ("uv_style", &[Is(1), Named('E')]),
                ("cam_dir", &[Is(1), Is(3)]),
            ],
            &[
                ("colors", &[Is(1), Named('U'), Named('U'), Named('C')]),
                ("opacities", &[Is(1), Named('U'), Named('U'), Is(1)]),
                ("scales", &[Is(1), Named('U'), Named('U'), Is(3)]),
                ("rotations", &[Is(1), Named('U'), Named('U'), Is(4)]),
                ("local_pos", &[Is(1), Named('U'), Named('U'), Is(3)]),
            ],
        ),
        // GUAVA renders and refines at its feature side (512²).
        Role::Refiner => (
            &[("splat", &[Is(1), Named('C'), Named('R'), Named('R')])],
            &[("rgb", &[Is(1), Is(3), Named('R'), Named('R')])],
        ),
    }
}

/// What a model file declares: enough to check it without running it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ModelInfo {
    pub format: Option<String>,
    pub role: Option<String>,
    pub inputs: Vec<(String, Vec<i64>)>,
    pub outputs: Vec<(String, Vec<i64>)>,
}

impl ModelInfo {
    fn of(session: &Session) -> Self {
        Self {
            format: session.metadata("guava_rs.format"),
            role: session.metadata("guava_rs.role"),
            inputs: session.input_shapes(),
            outputs: session.output_shapes(),
        }
    }
}

/// The sizes the three models agree on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dims {
    /// Encoder input side (518 for GUAVA: DINOv2's 37×37 patches of 14).
    pub image: usize,
    /// Feature-map side (GUAVA's render size, 512).
    pub features: usize,
    /// Channels of `pixel_features`: RGB and f_map1 (35).
    pub pixel_channels: usize,
    /// Channels of `vertex_features`, f_map2 (128).
    pub vertex_channels: usize,
    pub vertex_global: usize,
    pub uv_style: usize,
    /// Template Gaussians, one per body vertex (10,595 for GUAVA's SMPL-X with teeth).
    pub vertices: usize,
    /// UV map side (512).
    pub uv: usize,
    /// Channels per Gaussian (32); the first three are RGB.
    pub colors: usize,
}

/// Checks the four models' declarations against the interface the exporter writes and against
/// each other; every problem found, each naming its file.
pub fn check(infos: &BTreeMap<Role, ModelInfo>) -> Result<Dims, Vec<String>> {
    let mut problems = Vec::new();
    let mut named: BTreeMap<char, (i64, String)> = BTreeMap::new();
    for (&role, info) in infos {
        let file = role.file();
        if info.format.as_deref() != Some(FORMAT) {
            problems.push(format!(
                "{file}: exporter format {}, expected {FORMAT:?} (re-export it with tools/export_guava_onnx.py)",
                info.format
                    .as_ref()
                    .map_or("missing".to_string(), |f| format!("{f:?}"))
            ));
        }
        if info.role.as_deref() != Some(role.key()) {
            problems.push(format!(
                "{file}: its metadata says role {:?}, expected {:?} (files swapped or renamed?)",
                info.role.as_deref().unwrap_or("missing"),
                role.key()
            ));
            continue;
        }
        let (inputs, outputs) = interface(role);
        for (kind, wanted, found) in [
            ("input", inputs, &info.inputs),
            ("output", outputs, &info.outputs),
        ] {
            for (name, dims) in wanted.iter() {
                let Some((_, shape)) = found.iter().find(|(n, _)| n == name) else {
                    problems.push(format!("{file}: no {kind} {name:?}"));
                    continue;
                };
                if shape.len() != dims.len() {
                    problems.push(format!(
                        "{file}: {kind} {name:?} has shape {shape:?}, expected {} dimensions",
                        dims.len()
                    ));
                    continue;
                }
                for (axis, (&size, dim)) in shape.iter().zip(dims.iter()).enumerate() {
                    let at = format!("{file}: {kind} {name:?} dimension {axis}");
                    match *dim {
                        Is(n) if size != n => {
                            problems.push(format!("{at} is {size}, expected {n}"))
                        }
                        Is(_) => {}
                        Named(_) if size <= 0 => problems.push(format!(
                            "{at} is not fixed ({size}); export with fixed sizes"
                        )),
                        Named(letter) => match named.get(&letter) {
                            Some((n, by)) if *n != size => {
                                problems.push(format!("{at} is {size}, but {by} makes it {n}"))
                            }
                            Some(_) => {}
                            None => {
                                named.insert(letter, (size, format!("{file} {kind} {name:?}")));
                            }
                        },
                    }
                }
            }
        }
    }
    let get = |c: char| named.get(&c).map_or(0, |(n, _)| *n as usize);
    let dims = Dims {
        image: get('S'),
        features: get('R'),
        pixel_channels: get('X'),
        vertex_channels: get('P'),
        vertex_global: get('G'),
        uv_style: get('E'),
        vertices: get('N'),
        uv: get('U'),
        colors: get('C'),
    };
    if problems.is_empty() {
        if !dims.image.is_multiple_of(14) {
            problems.push(format!(
                "{}: image side {} is not a multiple of DINOv2's 14-pixel patch",
                Role::Encoder.file(),
                dims.image
            ));
        }
        if dims.pixel_channels < 4 || dims.colors < 3 {
            problems.push(format!(
                "pixel features need RGB and at least one learned channel ({} found) and Gaussians \
                 at least RGB ({} found)",
                dims.pixel_channels, dims.colors
            ));
        }
    }
    if problems.is_empty() {
        Ok(dims)
    } else {
        Err(problems)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum GuavaModelsError {
    #[error("GUAVA models in {}:\n  - {}", dir.display(), problems.join("\n  - "))]
    Invalid { dir: PathBuf, problems: Vec<String> },
    #[error(transparent)]
    Onnx(#[from] OnnxError),
}

/// The image's features: what the encoder gives, one image at a time.
pub struct Encoded {
    /// [`Dims::pixel_channels`] planes of [`Dims::features`]²: RGB (the image resized), then
    /// f_map1.
    pub pixel_features: Vec<f32>,
    /// [`Dims::vertex_channels`] planes of [`Dims::features`]² (f_map2).
    pub vertex_features: Vec<f32>,
    pub vertex_global: Vec<f32>,
    pub uv_style: Vec<f32>,
}

/// Raw decoder outputs, row-major as the models give them (per vertex, or per texel row by row);
/// activations as the reference applies them inside the decoders (sigmoid opacity; template
/// scales sigmoid·0.05, UV scales exp; colours raw).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DecodedGaussians {
    pub colors: Vec<f32>,
    pub opacities: Vec<f32>,
    pub scales: Vec<f32>,
    pub rotations: Vec<f32>,
    /// UV Gaussians only: offset in the triangle frame (units of the triangle's scale).
    pub local_pos: Vec<f32>,
}

pub struct GuavaModels {
    encoder: Session,
    vertex_decoder: Session,
    uv_decoder: Session,
    pub dims: Dims,
    /// Where the weights came from, as the exporter recorded it.
    pub source: String,
    pub dir: PathBuf,
}

impl GuavaModels {
    /// Loads and checks the four models in `dir`; one error lists everything missing or wrong.
    /// The refiner's session is dropped after the check (the frame path loads its own).
    pub fn load_dir(runtime: &OnnxRuntime, dir: &Path) -> Result<Self, GuavaModelsError> {
        let mut problems = Vec::new();
        let mut sessions = BTreeMap::new();
        for (role, file) in FILES {
            let path = dir.join(file);
            if !path.is_file() {
                problems.push(format!("{file}: missing"));
                continue;
            }
            match runtime.session(&path) {
                Ok(s) => {
                    sessions.insert(role, s);
                }
                Err(e) => problems.push(format!("{file}: {e}")),
            }
        }
        let invalid = |problems| GuavaModelsError::Invalid {
            dir: dir.to_path_buf(),
            problems,
        };
        if !problems.is_empty() {
            return Err(invalid(problems));
        }
        let infos = sessions
            .iter()
            .map(|(&r, s)| (r, ModelInfo::of(s)))
            .collect();
        let dims = check(&infos).map_err(invalid)?;
        let source = sessions[&Role::Encoder]
            .metadata("guava_rs.source")
            .unwrap_or_else(|| "unknown".into());
        let mut take = |r| sessions.remove(&r).expect("loaded above");
        Ok(Self {
            encoder: take(Role::Encoder),
            vertex_decoder: take(Role::VertexDecoder),
            uv_decoder: take(Role::UvDecoder),
            dims,
            source,
            dir: dir.to_path_buf(),
        })
    }

    /// GUAVA's refiner in the folder (checked with the others when the folder loaded).
    pub fn refiner_path(&self) -> PathBuf {
        self.dir.join(REFINER_FILE)
    }

    /// Runs the encoder on an [`Dims::image`]² RGB image in [0, 1], planar (all R, then G, B).
    pub fn encode(&mut self, image: &[f32]) -> Result<Encoded, OnnxError> {
        let s = self.dims.image;
        assert_eq!(image.len(), 3 * s * s, "{s}² planar RGB");
        let mut out = run(
            &mut self.encoder,
            vec![("image", tensor(vec![1, 3, s, s], image.to_vec()))],
        )?;
        let mut take = |name| out.remove(name).expect("outputs checked at load");
        Ok(Encoded {
            pixel_features: take("pixel_features"),
            vertex_features: take("vertex_features"),
            vertex_global: take("vertex_global"),
            uv_style: take("uv_style"),
        })
    }

    /// Template-Gaussian attributes from each vertex's sampled f_map2 features
    /// ([`Dims::vertices`] × [`Dims::vertex_channels`], row-major). `cam_dir` is GUAVA's camera
    /// direction (the third column of the world-to-camera rotation).
    pub fn decode_vertices(
        &mut self,
        sampled: Vec<f32>,
        encoded: &Encoded,
        cam_dir: Vec3,
    ) -> Result<DecodedGaussians, OnnxError> {
        let d = self.dims;
        let out = run(
            &mut self.vertex_decoder,
            vec![
                (
                    "sampled",
                    tensor(vec![1, d.vertices, d.vertex_channels], sampled),
                ),
                (
                    "vertex_global",
                    tensor(vec![1, d.vertex_global], encoded.vertex_global.clone()),
                ),
                ("cam_dir", tensor(vec![1, 3], cam_dir.to_array().to_vec())),
            ],
        )?;
        Ok(decoded(out, false))
    }

    /// UV-Gaussian attribute maps from the inverse-texture-mapped pixel features
    /// ([`Dims::pixel_channels`] planes of [`Dims::uv`]², invisible texels zero).
    pub fn decode_uv(
        &mut self,
        uv_features: Vec<f32>,
        encoded: &Encoded,
        cam_dir: Vec3,
    ) -> Result<DecodedGaussians, OnnxError> {
        let d = self.dims;
        let out = run(
            &mut self.uv_decoder,
            vec![
                (
                    "uv_features",
                    tensor(vec![1, d.pixel_channels, d.uv, d.uv], uv_features),
                ),
                (
                    "uv_style",
                    tensor(vec![1, d.uv_style], encoded.uv_style.clone()),
                ),
                ("cam_dir", tensor(vec![1, 3], cam_dir.to_array().to_vec())),
            ],
        )?;
        Ok(decoded(out, true))
    }
}

fn tensor(shape: Vec<usize>, data: Vec<f32>) -> TensorF32 {
    TensorF32 { shape, data }
}

/// Runs `session` and returns its outputs by name.
fn run(
    session: &mut Session,
    inputs: Vec<(&str, TensorF32)>,
) -> Result<BTreeMap<String, Vec<f32>>, OnnxError> {
    let names = session.output_names();
    Ok(names
        .into_iter()
        .zip(session.run(inputs)?)
        .map(|(n, t)| (n, t.data))
        .collect())
}

fn decoded(mut out: BTreeMap<String, Vec<f32>>, uv: bool) -> DecodedGaussians {
    let mut take = |name| out.remove(name).expect("outputs checked at load");
    DecodedGaussians {
        colors: take("colors"),
        opacities: take("opacities"),
        scales: take("scales"),
        rotations: take("rotations"),
        local_pos: if uv { take("local_pos") } else { Vec::new() },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The declarations the exporter writes, with every named size from `size`.
    fn declared(size: impl Fn(char) -> i64) -> BTreeMap<Role, ModelInfo> {
        let shapes = |tensors: Tensors| {
            tensors
                .iter()
                .map(|(name, dims)| {
                    let shape = dims
                        .iter()
                        .map(|d| match *d {
                            Is(n) => n,
                            Named(c) => size(c),
                        })
                        .collect();
                    (name.to_string(), shape)
                })
                .collect()
        };
        FILES
            .iter()
            .map(|&(role, _)| {
                let (inputs, outputs) = interface(role);
                let info = ModelInfo {
                    format: Some(FORMAT.into()),
                    role: Some(role.key().into()),
                    inputs: shapes(inputs),
                    outputs: shapes(outputs),
                };
                (role, info)
            })
            .collect()
    }

    fn guava_sizes(c: char) -> i64 {
        match c {
            'S' => 518,
            'R' | 'U' => 512,
            'X' => 35,
            'P' => 128,
            'G' => 256,
            'E' => 512,
            'N' => 10595,
            'C' => 32,
            _ => unreachable!(),
        }
    }

    #[test]
    fn guava_sizes_pass_and_are_read_back() {
        let dims = check(&declared(guava_sizes)).expect("consistent");
        assert_eq!(
            (
                dims.image,
                dims.features,
                dims.uv,
                dims.vertices,
                dims.pixel_channels
            ),
            (518, 512, 512, 10595, 35)
        );
    }

    #[test]
    fn another_exporter_version_and_disagreeing_sizes_are_each_named() {
        let mut infos = declared(guava_sizes);
        infos.get_mut(&Role::Encoder).expect("declared").format = Some("0".into());
        // The UV decoder expects one pixel-feature channel more than the encoder gives.
        infos.get_mut(&Role::UvDecoder).expect("declared").inputs[0].1[1] = 36;
        let problems = check(&infos).expect_err("must be refused");
        assert_eq!(problems.len(), 2, "{problems:?}");
        assert!(problems[0].starts_with("guava_encoder.onnx: exporter format \"0\""));
        assert!(
            problems[1]
                .starts_with("guava_uv_decoder.onnx: input \"uv_features\" dimension 1 is 36")
                && problems[1].contains("guava_encoder.onnx output \"pixel_features\" makes it 35"),
            "{problems:?}"
        );
    }

    #[test]
    fn a_refiner_for_other_channels_is_named() {
        let mut infos = declared(guava_sizes);
        infos.get_mut(&Role::Refiner).expect("declared").inputs[0].1[1] = 96;
        let problems = check(&infos).expect_err("must be refused");
        assert_eq!(problems.len(), 1, "{problems:?}");
        assert!(
            problems[0].starts_with("guava_refiner.onnx: input \"splat\" dimension 1 is 96"),
            "{problems:?}"
        );
    }

    #[test]
    fn dynamic_sizes_and_bad_patch_grids_are_refused() {
        let mut infos = declared(guava_sizes);
        infos
            .get_mut(&Role::VertexDecoder)
            .expect("declared")
            .inputs[0]
            .1[1] = -1;
        let problems = check(&infos).expect_err("dynamic");
        assert!(problems[0].contains("not fixed"), "{problems:?}");
        let problems = check(&declared(|c| if c == 'S' { 520 } else { guava_sizes(c) }))
            .expect_err("520 is no multiple of 14");
        assert!(
            problems[0].contains("multiple of DINOv2's 14-pixel patch"),
            "{problems:?}"
        );
    }
}
