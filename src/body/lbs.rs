//! Linear blend skinning primitives shared by the template model and EHM, with the reference's
//! exact conventions (`flame/lbs.py`: `batch_rodrigues`, `batch_rigid_transform`, `lbs`).

use glam::{Affine3A, Mat3A, Vec3, Vec3A};

/// Rotation matrix of an axis-angle vector exactly as `batch_rodrigues`: θ = |r + 1e-8| (the
/// epsilon added to each component), k = r/θ, R = I + sin θ·K + (1 − cos θ)·K². Non-finite input
/// is counted and treated as zero.
pub fn rodrigues(r: Vec3, nonfinite: &mut usize) -> Mat3A {
    if !r.is_finite() || !r.length_squared().is_finite() {
        *nonfinite += 1;
        return Mat3A::IDENTITY;
    }
    let angle = (r + Vec3::splat(1e-8)).length();
    let k = r / angle;
    let (sin, cos) = angle.sin_cos();
    let kx = Mat3A::from_cols(
        Vec3A::new(0.0, k.z, -k.y),
        Vec3A::new(-k.z, 0.0, k.x),
        Vec3A::new(k.y, -k.x, 0.0),
    );
    Mat3A::IDENTITY + kx * sin + (kx * kx) * (1.0 - cos)
}

/// Forward kinematics over joints whose parents precede them: world frames
/// G_j = G_parent·[R_j | J_j − J_parent] (the root: [R_0 | J_0 + root_offset]) and skinning
/// placements A_j = G_j·T(−J_j), which map rest space to posed space.
pub fn rigid_chain(
    parents: impl IntoIterator<Item = Option<usize>>,
    rest: &[Vec3],
    rotations: &[Mat3A],
    root_offset: Vec3,
    world: &mut Vec<Affine3A>,
    placements: &mut Vec<Affine3A>,
) {
    world.clear();
    placements.clear();
    for ((j, parent), r) in parents.into_iter().enumerate().zip(rotations) {
        let frame = match parent {
            Some(p) => world[p] * Affine3A::from_mat3_translation((*r).into(), rest[j] - rest[p]),
            None => Affine3A::from_mat3_translation((*r).into(), rest[j] + root_offset),
        };
        world.push(frame);
        placements.push(Affine3A {
            matrix3: frame.matrix3,
            translation: frame.translation - frame.matrix3 * Vec3A::from(rest[j]),
        });
    }
}

/// Σ w·A over a vertex's influences (the blended 3×4 part of `T = W·A`).
pub fn blend(influences: impl Iterator<Item = (usize, f32)>, placements: &[Affine3A]) -> Affine3A {
    let mut out = Affine3A {
        matrix3: Mat3A::ZERO,
        translation: Vec3A::ZERO,
    };
    for (j, w) in influences {
        let a = &placements[j];
        out.matrix3.x_axis += w * a.matrix3.x_axis;
        out.matrix3.y_axis += w * a.matrix3.y_axis;
        out.matrix3.z_axis += w * a.matrix3.z_axis;
        out.translation += w * a.translation;
    }
    out
}
