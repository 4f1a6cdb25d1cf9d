//! How much a tracked sequence moves from one frame to the next: joint rotations (the angle
//! each joint turns, summed over the joints), face units and the camera. On a still subject all
//! of it is jitter; on a moving one, jitter is what exceeds the truth's own change (known for
//! synthetic videos).

use glam::{Quat, Vec3};

use crate::tracking::Tracking;

/// Mean change per frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Jitter {
    /// Σ over joints of the angle turned, in degrees.
    pub rotation_deg: f64,
    /// Σ over the frame's values (face units, eyelids…) of their change.
    pub values: f64,
    /// The camera's movement, in millimetres.
    pub camera_mm: f64,
}

impl Jitter {
    pub fn of(tracking: &Tracking) -> Self {
        let frames = &tracking.frames;
        let pairs = frames.len().saturating_sub(1).max(1) as f64;
        let mut sum = Self::default();
        for pair in frames.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            sum.rotation_deg += a
                .rotations
                .iter()
                .zip(&b.rotations)
                .map(|(&p, &q)| {
                    let (p, q) = (
                        Quat::from_scaled_axis(p.into()),
                        Quat::from_scaled_axis(q.into()),
                    );
                    f64::from(p.angle_between(q)).to_degrees()
                })
                .sum::<f64>();
            sum.values += a
                .values
                .iter()
                .zip(&b.values)
                .map(|(p, q)| f64::from((p - q).abs()))
                .sum::<f64>();
            if let (Some(p), Some(q)) = (a.camera, b.camera) {
                // The camera's centre in the world: −Rᵀt.
                let centre = |w2c: [[f32; 4]; 3]| {
                    let r = glam::Mat3::from_cols_array_2d(&[
                        [w2c[0][0], w2c[1][0], w2c[2][0]],
                        [w2c[0][1], w2c[1][1], w2c[2][1]],
                        [w2c[0][2], w2c[1][2], w2c[2][2]],
                    ]);
                    -(r.transpose() * Vec3::new(w2c[0][3], w2c[1][3], w2c[2][3]))
                };
                sum.camera_mm += f64::from(centre(p.w2c).distance(centre(q.w2c))) * 1e3;
            }
        }
        Self {
            rotation_deg: sum.rotation_deg / pairs,
            values: sum.values / pairs,
            camera_mm: sum.camera_mm / pairs,
        }
    }
}
