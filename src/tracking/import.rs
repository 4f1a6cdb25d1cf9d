//! Motion files from other tools, turned into [`Tracking`]:
//! - ARKit-52 blendshape CSV as written by face-capture apps (Live Link Face: `Timecode,
//!   BlendShapeCount, EyeBlinkLeft, …`), for the default body's ARKit face;
//! - SMPL-X parameter `.npz` files: AMASS (`poses` \[N,165\] or SMPL-H \[N,156\], `trans`, `betas`,
//!   `mocap_frame_rate`; z-up, turned to y-up) or per-part fits (`global_orient`, `body_pose`,
//!   `jaw_pose`, `leye_pose`, `reye_pose`, `left/right_hand_pose`, `transl`, `expression`, `betas`).
//!
//! Each import says what it could not carry over (`Imported::notes`), e.g. CSV head-rotation columns.

use std::path::Path;

use glam::{Quat, Vec3};

use super::format::{BodyKind, Frame, Tracking, TrackingError};
use crate::body::SMPLX_JOINTS;
use crate::npz::Npz;

/// Apple ARKit's 52 face blendshapes, as the default body names its expression targets.
pub const ARKIT_BLENDSHAPES: [&str; 52] = [
    "browDownLeft",
    "browDownRight",
    "browInnerUp",
    "browOuterUpLeft",
    "browOuterUpRight",
    "cheekPuff",
    "cheekSquintLeft",
    "cheekSquintRight",
    "eyeBlinkLeft",
    "eyeBlinkRight",
    "eyeLookDownLeft",
    "eyeLookDownRight",
    "eyeLookInLeft",
    "eyeLookInRight",
    "eyeLookOutLeft",
    "eyeLookOutRight",
    "eyeLookUpLeft",
    "eyeLookUpRight",
    "eyeSquintLeft",
    "eyeSquintRight",
    "eyeWideLeft",
    "eyeWideRight",
    "jawForward",
    "jawLeft",
    "jawOpen",
    "jawRight",
    "mouthClose",
    "mouthDimpleLeft",
    "mouthDimpleRight",
    "mouthFrownLeft",
    "mouthFrownRight",
    "mouthFunnel",
    "mouthLeft",
    "mouthLowerDownLeft",
    "mouthLowerDownRight",
    "mouthPressLeft",
    "mouthPressRight",
    "mouthPucker",
    "mouthRight",
    "mouthRollLower",
    "mouthRollUpper",
    "mouthShrugLower",
    "mouthShrugUpper",
    "mouthSmileLeft",
    "mouthSmileRight",
    "mouthStretchLeft",
    "mouthStretchRight",
    "mouthUpperUpLeft",
    "mouthUpperUpRight",
    "noseSneerLeft",
    "noseSneerRight",
    "tongueOut",
];

/// Frame rate assumed when a CSV's timecodes span less than a second.
pub const CSV_DEFAULT_FPS: f32 = 60.0;
/// Frame rate assumed when an SMPL-X file does not record one.
pub const NPZ_DEFAULT_FPS: f32 = 30.0;

/// An imported motion and what the import could not carry over or had to assume.
#[derive(Clone, Debug)]
pub struct Imported {
    pub tracking: Tracking,
    pub notes: Vec<String>,
}

/// Opens any supported motion file by its extension: `.json` (ours), `.csv`, `.npz`.
pub fn open_motion(path: &Path) -> Result<Imported, TrackingError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("json") => Ok(Imported {
            tracking: Tracking::load(path)?,
            notes: Vec::new(),
        }),
        Some("csv") => arkit_csv(path),
        Some("npz") => smplx_npz(path),
        _ => Err(TrackingError {
            file: path.display().to_string(),
            frame: None,
            field: "file".into(),
            problem: "not a motion file (expected .json tracking, ARKit .csv or SMPL-X .npz)"
                .into(),
        }),
    }
}

fn error(
    file: &str,
    frame: Option<usize>,
    field: impl Into<String>,
    problem: impl Into<String>,
) -> TrackingError {
    TrackingError {
        file: file.into(),
        frame,
        field: field.into(),
        problem: problem.into(),
    }
}

/// Reads an ARKit blendshape CSV. Columns are matched to the 52 ARKit names case-insensitively;
/// the frame rate comes from the `Timecode` column (`HH:MM:SS:FF.sss`: the largest `FF` + 1)
/// when it spans a second or more, else [`CSV_DEFAULT_FPS`].
pub fn arkit_csv(path: &Path) -> Result<Imported, TrackingError> {
    let file = path.display().to_string();
    let text =
        std::fs::read_to_string(path).map_err(|e| error(&file, None, "file", e.to_string()))?;
    parse_arkit_csv(&text, &file)
}

pub fn parse_arkit_csv(text: &str, file: &str) -> Result<Imported, TrackingError> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<&str> = lines
        .next()
        .ok_or_else(|| error(file, None, "header", "the file is empty"))?
        .split(',')
        .map(str::trim)
        .collect();
    let timecode = header
        .iter()
        .position(|h| h.eq_ignore_ascii_case("timecode"));
    let mut columns = Vec::new();
    let mut skipped = Vec::new();
    for (c, h) in header.iter().enumerate() {
        if let Some(name) = ARKIT_BLENDSHAPES.iter().find(|n| n.eq_ignore_ascii_case(h)) {
            columns.push((c, *name));
        } else if Some(c) != timecode && !h.eq_ignore_ascii_case("blendshapecount") {
            skipped.push(h.to_string());
        }
    }
    if columns.is_empty() {
        return Err(error(
            file,
            None,
            "header",
            "no ARKit blendshape columns (EyeBlinkLeft, JawOpen, …)",
        ));
    }
    let mut tracking = Tracking::new(
        BodyKind::Default,
        CSV_DEFAULT_FPS,
        Vec::new(),
        columns.iter().map(|(_, n)| (*n).to_owned()).collect(),
    );
    tracking.source = format!("ARKit blendshape CSV {file}");
    let (mut first_second, mut last_second, mut max_ff) = (None, 0.0f64, 0u32);
    for (f, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != header.len() {
            return Err(error(
                file,
                Some(f),
                format!("line {}", f + 2),
                format!("{} cells, the header has {}", cells.len(), header.len()),
            ));
        }
        if let Some(t) = timecode {
            let (seconds, ff) = parse_timecode(cells[t]).ok_or_else(|| {
                error(
                    file,
                    Some(f),
                    "Timecode",
                    format!("{:?} is not HH:MM:SS:FF", cells[t]),
                )
            })?;
            first_second.get_or_insert(seconds);
            last_second = seconds;
            max_ff = max_ff.max(ff);
        }
        let values = columns
            .iter()
            .map(|&(c, name)| {
                cells[c].parse::<f32>().map_err(|_| {
                    error(
                        file,
                        Some(f),
                        name,
                        format!("{:?} is not a number", cells[c]),
                    )
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        tracking.frames.push(Frame {
            translation: [0.0; 3],
            rotations: Vec::new(),
            values,
            camera: None,
        });
    }
    let mut notes = Vec::new();
    match first_second {
        Some(first) if last_second - first >= 1.0 => tracking.fps = (max_ff + 1) as f32,
        _ => notes.push(format!(
            "frame rate taken as {CSV_DEFAULT_FPS} fps (no timecodes spanning a second)"
        )),
    }
    if !skipped.is_empty() {
        notes.push(format!(
            "columns not imported (not ARKit blendshapes; head and eye rotations are not read \
             because apps disagree on their units): {}",
            skipped.join(", ")
        ));
    }
    tracking.validate(file)?;
    Ok(Imported { tracking, notes })
}

/// `HH:MM:SS:FF.sss` → (whole seconds since midnight, frame number FF).
fn parse_timecode(tc: &str) -> Option<(f64, u32)> {
    let parts: Vec<&str> = tc.split(':').collect();
    let [h, m, s, ff] = parts.as_slice() else {
        return None;
    };
    let whole = |x: &str| x.parse::<u32>().ok();
    let frame = ff.split('.').next()?;
    // In f64: hours as large as a u32 holds must not overflow (found by tests/fuzz.rs).
    let seconds = |x: &str| whole(x).map(f64::from);
    Some((
        seconds(h)? * 3600.0 + seconds(m)? * 60.0 + seconds(s)?,
        whole(frame)?,
    ))
}

/// SMPL-H's 52 joints are SMPL-X's first 22 followed by the 30 finger joints (no jaw, no eyes).
const SMPLH_TO_SMPLX: std::ops::Range<usize> = 25..55;

/// Reads an SMPL-X (or SMPL-H, AMASS) parameter archive.
pub fn smplx_npz(path: &Path) -> Result<Imported, TrackingError> {
    let file = path.display().to_string();
    let npz = Npz::open(path).map_err(|e| error(&file, None, "file", e.problem))?;
    smplx_from_npz(&npz)
}

pub fn smplx_from_npz(npz: &Npz) -> Result<Imported, TrackingError> {
    let file = npz.file().to_owned();
    let fail = |e: crate::npz::NpzError| {
        let (field, problem) = e.problem.split_once(": ").unwrap_or(("file", &e.problem));
        error(&file, None, field, problem)
    };
    let mut notes = Vec::new();
    // Per joint, per frame axis-angles; missing parts stay at rest.
    let (rotations, frames) = if npz.contains("poses") {
        let shape = npz.shape("poses").map_err(fail)?.to_vec();
        let (data, _) = npz.f32s("poses", &[None, None]).map_err(fail)?;
        let n = shape[0];
        let mut rotations = vec![vec![[0.0f32; 3]; 55]; n];
        match shape[1] {
            165 => {
                for (f, r) in rotations.iter_mut().enumerate() {
                    for (j, x) in r.iter_mut().enumerate() {
                        x.copy_from_slice(&data[f * 165 + 3 * j..f * 165 + 3 * j + 3]);
                    }
                }
            }
            156 => {
                notes.push("SMPL-H poses: jaw and eyes stay at rest".into());
                let joints = (0..22).chain(SMPLH_TO_SMPLX);
                for (f, r) in rotations.iter_mut().enumerate() {
                    for (k, j) in joints.clone().enumerate() {
                        r[j].copy_from_slice(&data[f * 156 + 3 * k..f * 156 + 3 * k + 3]);
                    }
                }
            }
            other => {
                return Err(error(
                    &file,
                    None,
                    "poses",
                    format!("{other} values per frame, expected 165 (SMPL-X) or 156 (SMPL-H)"),
                ));
            }
        }
        (rotations, n)
    } else {
        let parts: [(&str, usize, usize); 7] = [
            ("global_orient", 0, 1),
            ("body_pose", 1, 21),
            ("jaw_pose", 22, 1),
            ("leye_pose", 23, 1),
            ("reye_pose", 24, 1),
            ("left_hand_pose", 25, 15),
            ("right_hand_pose", 40, 15),
        ];
        let frames = parts
            .iter()
            .find(|(name, ..)| npz.contains(name))
            .map(|(name, ..)| npz.shape(name).map(|s| if s.len() > 1 { s[0] } else { 1 }))
            .transpose()
            .map_err(fail)?
            .ok_or_else(|| {
                error(
                    &file,
                    None,
                    "poses",
                    "no SMPL-X pose arrays (poses, or global_orient/body_pose/…)",
                )
            })?;
        let mut rotations = vec![vec![[0.0f32; 3]; 55]; frames];
        for (name, first, count) in parts {
            if !npz.contains(name) {
                notes.push(format!("{name} missing: those joints stay at rest"));
                continue;
            }
            let shape = npz.shape(name).map_err(fail)?.to_vec();
            let per_frame = shape.iter().skip(1).product::<usize>();
            if shape.iter().product::<usize>() != frames * 3 * count {
                let hint = if count == 15 && shape.len() == 2 && per_frame < 45 {
                    " (a PCA hand pose? save the full 45-value axis-angle pose)"
                } else {
                    ""
                };
                return Err(error(
                    &file,
                    None,
                    name,
                    format!("shape {shape:?}, expected {frames} frames of {count}×3 values{hint}"),
                ));
            }
            let expected: Vec<Option<usize>> = shape.iter().map(|&d| Some(d)).collect();
            let (data, _) = npz.f32s(name, &expected).map_err(fail)?;
            for (f, r) in rotations.iter_mut().enumerate() {
                for k in 0..count {
                    let at = f * 3 * count + 3 * k;
                    r[first + k].copy_from_slice(&data[at..at + 3]);
                }
            }
        }
        (rotations, frames)
    };
    // A single frame may come as 1-D arrays (SMPL-X's per-part parameter files), as the pose
    // arrays and `betas` may: read [n] as [1, n].
    let one_dimensional = |key: &str| -> Result<bool, crate::npz::NpzError> {
        Ok(frames == 1 && npz.shape(key)?.len() == 1)
    };
    let translation_key = ["trans", "transl"].into_iter().find(|k| npz.contains(k));
    let translations = match translation_key {
        Some(key) => {
            let shape: &[Option<usize>] = if one_dimensional(key).map_err(fail)? {
                &[Some(3)]
            } else {
                &[Some(frames), Some(3)]
            };
            npz.f32s(key, shape).map_err(fail)?.0.to_vec()
        }
        None => {
            notes.push("no trans/transl: the body stays at the origin".into());
            vec![0.0; 3 * frames]
        }
    };
    let expression = if npz.contains("expression") {
        let shape: &[Option<usize>] = if one_dimensional("expression").map_err(fail)? {
            &[None]
        } else {
            &[Some(frames), None]
        };
        let (data, shape) = npz.f32s("expression", shape).map_err(fail)?;
        (*shape.last().expect("one axis at least"), data.to_vec())
    } else {
        (0, Vec::new())
    };
    let rate_key = ["mocap_frame_rate", "mocap_framerate", "fps"]
        .into_iter()
        .find(|k| npz.contains(k));
    let fps = match rate_key {
        Some(key) => npz.f32s(key, &[]).map_err(fail)?.0[0],
        None => {
            notes.push(format!(
                "no frame rate recorded: taken as {NPZ_DEFAULT_FPS} fps"
            ));
            NPZ_DEFAULT_FPS
        }
    };
    // AMASS is z-up; our bodies are y-up. Turning the root about the world origin leaves a
    // constant offset of (Rx − I)·pelvis, which framing the camera absorbs.
    let z_up = ["mocap_frame_rate", "mocap_framerate", "surface_model_type"]
        .iter()
        .any(|k| npz.contains(k));
    let up = if z_up {
        notes.push("AMASS file: turned from z-up to y-up".into());
        Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2)
    } else {
        Quat::IDENTITY
    };
    let mut tracking = Tracking::new(
        BodyKind::Smplx,
        fps,
        SMPLX_JOINTS.iter().map(|s| (*s).to_owned()).collect(),
        (0..expression.0)
            .map(|i| format!("expression_{i:03}"))
            .collect(),
    );
    tracking.source = format!("SMPL-X parameters {file}");
    if npz.contains("betas") {
        let shape = npz.shape("betas").map_err(fail)?.to_vec();
        let expected: Vec<Option<usize>> = shape.iter().map(|&d| Some(d)).collect();
        let (betas, _) = npz.f32s("betas", &expected).map_err(fail)?;
        // One row of betas (a per-frame array repeats the same shape).
        let count = shape.last().copied().unwrap_or(betas.len());
        for (i, &b) in betas.iter().take(count).enumerate() {
            tracking
                .identity
                .parameters
                .insert(format!("shape_{i:03}"), b);
        }
    }
    for (f, mut r) in rotations.into_iter().enumerate() {
        if z_up {
            r[0] = (up * Quat::from_scaled_axis(Vec3::from(r[0])))
                .to_scaled_axis()
                .into();
        }
        let t = Vec3::from_slice(&translations[3 * f..3 * f + 3]);
        tracking.frames.push(Frame {
            translation: (up * t).into(),
            rotations: r,
            values: expression.1[f * expression.0..(f + 1) * expression.0].to_vec(),
            camera: None,
        });
    }
    tracking.validate(&file)?;
    Ok(Imported { tracking, notes })
}
