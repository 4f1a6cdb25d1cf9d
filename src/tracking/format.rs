//! The tracking file: one JSON document, format "guava-rs tracking 1" (documented in
//! `docs/tracking-format.md`). Channel names are listed once in the header; every frame stores
//! values in that order, so the file stays readable and ~10 bytes per number for long sequences.
//!
//! [`Tracking::load`] parses and then validates everything playback relies on; every error names
//! the file, the frame (when there is one) and the field.

use std::collections::{BTreeMap, HashSet};
use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

pub const TRACKING_FORMAT: &str = "guava-rs tracking 1";

/// Largest accepted rotation angle (radians). Trackers unwrap angles a little past π; beyond two
/// full turns a value is a unit or layout mistake, not a pose.
pub const MAX_ROTATION: f32 = 4.0 * std::f32::consts::PI;
/// Largest accepted |coefficient|. Shape, expression and blendshape weights live within ±10
/// (FLAME/SMPL-X PCA units, ARKit 0…1); 100 only rejects garbage.
pub const MAX_COEFFICIENT: f32 = 100.0;
/// Largest accepted |translation| (metres) of the body or the camera.
pub const MAX_TRANSLATION: f32 = 1000.0;
/// Tolerance on a camera rotation's orthonormality.
const ROTATION_TOLERANCE: f32 = 1e-3;

/// Which rig the channel names and rest pose belong to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BodyKind {
    /// SMPL-X / EHM joint names (`pelvis`, `left_shoulder`, …), T-pose rest (arms along ±x).
    Smplx,
    /// The default body's rig (`root`, `upperarm01.L`, …, ARKit face units), A-pose rest.
    Default,
}

/// A tracked sequence: shared identity plus per-frame pose, expression and camera.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tracking {
    pub format: String,
    pub body: BodyKind,
    /// Frames per second; frame `i` is at time `i / fps`.
    pub fps: f32,
    /// Where the data came from (free text, shown to the user).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub source: String,
    /// Joint names, in the order of every frame's `rotations`.
    pub joints: Vec<String>,
    /// Coefficient names (expression, eyelids, blendshapes), in the order of every frame's `values`.
    pub parameters: Vec<String>,
    #[serde(default)]
    pub identity: Identity,
    /// Whether the motion is layered on the pose it drives (an authored motion, such as the
    /// demo's) instead of replacing it (a tracked one): each rotation turns its joint on from
    /// where the pose has it, each value adds to the pose's, so its first frame, at rest, leaves
    /// an avatar as its photo shows it.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub layered: bool,
    pub frames: Vec<Frame>,
}

/// What stays fixed over the sequence.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Identity {
    /// Shape coefficients by name (`shape_000`, `flame_shape_000`, or the default body's shape names).
    #[serde(default)]
    pub parameters: BTreeMap<String, f32>,
    /// EHM's per-avatar skeleton adjustments (only an EHM body uses them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ehm: Option<EhmIdentityRecord>,
}

/// EHM-Tracker's `joints_offset`, `head_scale`, `hand_scale`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EhmIdentityRecord {
    /// Added to the 55 SMPL-X rest joints (metres).
    pub joints_offset: Vec<[f32; 3]>,
    pub head_scale: [f32; 3],
    pub hand_scale: [f32; 3],
}

impl EhmIdentityRecord {
    /// The record of an EHM body's identity.
    pub fn of(identity: &crate::body::EhmIdentity) -> Self {
        Self {
            joints_offset: identity
                .joints_offset
                .iter()
                .map(|o| o.to_array())
                .collect(),
            head_scale: identity.head_scale.to_array(),
            hand_scale: identity.hand_scale.to_array(),
        }
    }

    /// Checks what posing relies on: one offset per SMPL-X joint, finite offsets under a metre,
    /// scales in (0, 10]. The error is (field, problem).
    pub fn check(&self) -> Result<(), (String, String)> {
        let joints = crate::body::SMPLX_JOINTS.len();
        if self.joints_offset.len() != joints {
            return Err((
                "joints_offset".into(),
                format!(
                    "{} offsets, expected {joints} (one per SMPL-X joint)",
                    self.joints_offset.len()
                ),
            ));
        }
        for (j, o) in self.joints_offset.iter().enumerate() {
            check_vector(o, 1.0).map_err(|p| (format!("joints_offset[{j}]"), p))?;
        }
        for (field, s) in [
            ("head_scale", self.head_scale),
            ("hand_scale", self.hand_scale),
        ] {
            if let Some(x) = s
                .iter()
                .find(|x| !(x.is_finite() && **x > 0.0 && **x <= 10.0))
            {
                return Err((field.into(), format!("{x} is not in (0, 10]")));
            }
        }
        Ok(())
    }

    /// The identity an EHM body is built with (`EhmModel::identity`).
    pub fn to_identity(&self) -> crate::body::EhmIdentity {
        crate::body::EhmIdentity {
            joints_offset: self.joints_offset.iter().map(|&o| o.into()).collect(),
            head_scale: self.head_scale.into(),
            hand_scale: self.hand_scale.into(),
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Frame {
    /// Added to every posed point (metres, model space).
    pub translation: [f32; 3],
    /// Axis-angle per joint (radians), in the rig's world-aligned joint frames.
    pub rotations: Vec<[f32; 3]>,
    pub values: Vec<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<TrackedCamera>,
}

/// GUAVA's camera: world→camera `[R | t]` in OpenCV axes (x right, y down, z forward), rows of a
/// 3×4 matrix, and `invtanfov` = 1/tan(fov/2) of the square image.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackedCamera {
    pub w2c: [[f32; 4]; 3],
    pub invtanfov: f32,
    /// The square of the source photo this camera's image is, `[left, top, side]` in the photo's
    /// pixels (it may reach past the photo's edges); absent: the photo's centred square.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crop: Option<[i64; 3]>,
}

/// Largest accepted photo coordinate of a crop, in pixels.
const MAX_CROP: i64 = 1 << 20;

#[derive(Debug, thiserror::Error)]
#[error("{file}: {}{field}: {problem}", frame.map(|f| format!("frame {f}: ")).unwrap_or_default())]
pub struct TrackingError {
    pub file: String,
    pub frame: Option<usize>,
    pub field: String,
    pub problem: String,
}

impl Tracking {
    /// An empty sequence for `body` at `fps` with the given channels (add frames, then validate).
    pub fn new(body: BodyKind, fps: f32, joints: Vec<String>, parameters: Vec<String>) -> Self {
        Self {
            format: TRACKING_FORMAT.into(),
            body,
            fps,
            source: String::new(),
            joints,
            parameters,
            identity: Identity::default(),
            layered: false,
            frames: Vec::new(),
        }
    }

    pub fn load(path: &Path) -> Result<Self, TrackingError> {
        let file = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| TrackingError {
            file: file.clone(),
            frame: None,
            field: "file".into(),
            problem: e.to_string(),
        })?;
        Self::from_json(&bytes, &file)
    }

    /// Parses and validates; `file` names the source in errors.
    pub fn from_json(bytes: &[u8], file: &str) -> Result<Self, TrackingError> {
        let mut de = serde_json::Deserializer::from_slice(bytes);
        let tracking: Self = serde_path_to_error::deserialize(&mut de).map_err(|e| {
            let path = e.path().to_string();
            let frame = frame_of_path(&path);
            TrackingError {
                file: file.into(),
                frame,
                field: if path == "." { "document".into() } else { path },
                problem: e.into_inner().to_string(),
            }
        })?;
        de.end().map_err(|e| TrackingError {
            file: file.into(),
            frame: None,
            field: "document".into(),
            problem: e.to_string(),
        })?;
        tracking.validate(file)?;
        Ok(tracking)
    }

    /// Validates, then writes atomically: an indented header and one line per frame.
    pub fn save(&self, path: &Path) -> Result<(), TrackingError> {
        let file = path.display().to_string();
        self.validate(&file)?;
        crate::atomic_file::write_atomic(path, |out| self.write_json(out)).map_err(|e| {
            TrackingError {
                file,
                frame: None,
                field: "file".into(),
                problem: e.to_string(),
            }
        })
    }

    fn write_json(&self, out: &mut impl Write) -> std::io::Result<()> {
        let header = Self {
            frames: Vec::new(),
            ..self.clone()
        };
        let header = serde_json::to_string_pretty(&header)?;
        // The header ends with `"frames": []` and `}`; put the frames in between, one per line.
        let header = header
            .trim_end()
            .strip_suffix("[]\n}")
            .ok_or_else(|| std::io::Error::other("unexpected header layout"))?;
        out.write_all(header.as_bytes())?;
        out.write_all(b"[\n")?;
        for (i, frame) in self.frames.iter().enumerate() {
            out.write_all(b"    ")?;
            serde_json::to_writer(&mut *out, frame)?;
            out.write_all(if i + 1 < self.frames.len() {
                b",\n"
            } else {
                b"\n"
            })?;
        }
        out.write_all(b"  ]\n}\n")
    }

    /// Seconds from the first to the last frame.
    pub fn duration(&self) -> f64 {
        self.frames.len().saturating_sub(1) as f64 / self.fps as f64
    }

    /// Checks everything playback relies on.
    pub fn validate(&self, file: &str) -> Result<(), TrackingError> {
        let fail = |frame: Option<usize>, field: String, problem: String| TrackingError {
            file: file.into(),
            frame,
            field,
            problem,
        };
        if self.format != TRACKING_FORMAT {
            return Err(fail(
                None,
                "format".into(),
                format!("{:?}, expected {TRACKING_FORMAT:?}", self.format),
            ));
        }
        if !(self.fps.is_finite() && self.fps > 0.0 && self.fps <= 1000.0) {
            return Err(fail(
                None,
                "fps".into(),
                format!("{} is not in (0, 1000]", self.fps),
            ));
        }
        for (field, names) in [("joints", &self.joints), ("parameters", &self.parameters)] {
            let mut seen = HashSet::new();
            for (i, name) in names.iter().enumerate() {
                if name.is_empty() || !seen.insert(name.as_str()) {
                    let what = if name.is_empty() { "empty" } else { "repeated" };
                    return Err(fail(
                        None,
                        format!("{field}[{i}]"),
                        format!("{what} name {name:?}"),
                    ));
                }
            }
        }
        for (name, &v) in &self.identity.parameters {
            check_scalar(v, MAX_COEFFICIENT)
                .map_err(|p| fail(None, format!("identity.parameters.{name}"), p))?;
        }
        if let Some(ehm) = &self.identity.ehm {
            ehm.check()
                .map_err(|(field, p)| fail(None, format!("identity.ehm.{field}"), p))?;
        }
        if self.frames.is_empty() {
            return Err(fail(None, "frames".into(), "no frames".into()));
        }
        let with_camera = self.frames[0].camera.is_some();
        for (f, frame) in self.frames.iter().enumerate() {
            let at = Some(f);
            check_vector(&frame.translation, MAX_TRANSLATION)
                .map_err(|p| fail(at, "translation".into(), p))?;
            for (field, got, expected) in [
                ("rotations", frame.rotations.len(), self.joints.len()),
                ("values", frame.values.len(), self.parameters.len()),
            ] {
                if got != expected {
                    return Err(fail(
                        at,
                        field.into(),
                        format!("{got} entries, the header lists {expected}"),
                    ));
                }
            }
            for (j, r) in frame.rotations.iter().enumerate() {
                check_vector(r, MAX_ROTATION)
                    .map_err(|p| fail(at, format!("rotations[{j}] ({})", self.joints[j]), p))?;
            }
            for (i, &v) in frame.values.iter().enumerate() {
                check_scalar(v, MAX_COEFFICIENT)
                    .map_err(|p| fail(at, format!("values[{i}] ({})", self.parameters[i]), p))?;
            }
            match (&frame.camera, with_camera) {
                (Some(camera), true) => {
                    check_camera(camera).map_err(|(field, p)| fail(at, field, p))?
                }
                (None, false) => {}
                (_, expected) => {
                    return Err(fail(
                        at,
                        "camera".into(),
                        format!(
                            "{} here but {} in frame 0 (all frames or none)",
                            if expected { "missing" } else { "present" },
                            if expected { "present" } else { "missing" },
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// `frames[12].values[3]` → frame 12.
fn frame_of_path(path: &str) -> Option<usize> {
    let rest = path.strip_prefix("frames[")?;
    rest[..rest.find(']')?].parse().ok()
}

fn check_scalar(v: f32, limit: f32) -> Result<(), String> {
    if !v.is_finite() {
        Err(format!("{v} is not finite"))
    } else if v.abs() > limit {
        Err(format!("{v} is outside ±{limit}"))
    } else {
        Ok(())
    }
}

/// Finite, and the vector's length at most `limit`.
fn check_vector(v: &[f32; 3], limit: f32) -> Result<(), String> {
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return Err(format!("{x} is not finite"));
    }
    let length = glam::Vec3::from_array(*v).length();
    if length > limit {
        return Err(format!("{v:?} has length {length}, more than {limit}"));
    }
    Ok(())
}

fn check_camera(camera: &TrackedCamera) -> Result<(), (String, String)> {
    let fail = |field: &str, p: String| (format!("camera.{field}"), p);
    if !(camera.invtanfov.is_finite() && camera.invtanfov > 0.0 && camera.invtanfov <= 1e4) {
        return Err(fail(
            "invtanfov",
            format!("{} is not in (0, 1e4]", camera.invtanfov),
        ));
    }
    let m = camera.w2c;
    if let Some(x) = m.iter().flatten().find(|x| !x.is_finite()) {
        return Err(fail("w2c", format!("{x} is not finite")));
    }
    let r = glam::Mat3::from_cols_array_2d(&[
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ]);
    let error = (r.transpose() * r - glam::Mat3::IDENTITY)
        .to_cols_array()
        .iter()
        .fold(0.0f32, |a, x| a.max(x.abs()));
    if error > ROTATION_TOLERANCE || r.determinant() <= 0.0 {
        return Err(fail(
            "w2c",
            format!(
                "rotation part is not a rotation (|RᵀR − I| = {error:.2e}, det = {:.3})",
                r.determinant()
            ),
        ));
    }
    check_vector(&[m[0][3], m[1][3], m[2][3]], MAX_TRANSLATION)
        .map_err(|p| fail("w2c translation", p))?;
    if let Some([left, top, side]) = camera.crop
        && !(side > 0 && side <= MAX_CROP && left.abs() <= MAX_CROP && top.abs() <= MAX_CROP)
    {
        return Err(fail(
            "crop",
            format!(
                "[{left}, {top}, {side}] is not a square [left, top, side] with a side in \
                 (0, {MAX_CROP}] and corners within ±{MAX_CROP} pixels"
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_index_is_read_from_the_json_path() {
        assert_eq!(frame_of_path("frames[12].values[3]"), Some(12));
        assert_eq!(frame_of_path("fps"), None);
    }
}
