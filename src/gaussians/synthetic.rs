//! Seeded synthetic clouds for tests, benchmarks and the viewer's test scene. Deterministic across
//! platforms (SplitMix64), so fixtures and figures reproduce.

use super::GaussianCloud;

/// SplitMix64: tiny, fast, and good enough for test data.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    /// Uniform unit quaternion (Shoemake), (w, x, y, z).
    pub fn unit_quaternion(&mut self) -> [f32; 4] {
        let (u1, u2, u3) = (self.f32(), self.f32(), self.f32());
        let tau = std::f32::consts::TAU;
        let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
        [
            b * (tau * u3).cos(),
            a * (tau * u2).sin(),
            a * (tau * u2).cos(),
            b * (tau * u3).sin(),
        ]
    }
}

/// Parameters of a random cloud: centres uniform in a ball, log-uniform anisotropic scales.
#[derive(Clone, Debug)]
pub struct BallCloud {
    pub count: usize,
    pub channels: usize,
    pub radius: f32,
    pub scale_range: (f32, f32),
    pub opacity_range: (f32, f32),
    pub seed: u64,
}

impl BallCloud {
    pub fn new(count: usize, channels: usize, seed: u64) -> Self {
        Self {
            count,
            channels,
            radius: 1.0,
            scale_range: (0.004, 0.04),
            opacity_range: (0.05, 1.0),
            seed,
        }
    }

    pub fn generate(&self) -> GaussianCloud {
        let mut rng = Rng::new(self.seed);
        let mut cloud = GaussianCloud::new(self.channels);
        let mut feats = vec![0.0; self.channels];
        let (ls0, ls1) = (self.scale_range.0.ln(), self.scale_range.1.ln());
        for _ in 0..self.count {
            let p = loop {
                let p = [
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                ];
                if p[0] * p[0] + p[1] * p[1] + p[2] * p[2] <= 1.0 {
                    break p.map(|v| v * self.radius);
                }
            };
            let s = [0; 3].map(|_| rng.range(ls0, ls1).exp());
            let q = rng.unit_quaternion();
            let o = rng.range(self.opacity_range.0, self.opacity_range.1);
            feats.iter_mut().for_each(|f| *f = rng.f32());
            cloud.push(p, q, s, o, &feats);
        }
        cloud
    }
}

/// The viewer's test scene: a torus knot of Gaussians coloured by hue around the curve, so
/// orientation, depth order and anisotropy are easy to judge by eye. Labelled as a test scene.
pub fn torus_knot(count: usize, seed: u64) -> GaussianCloud {
    let mut rng = Rng::new(seed);
    let mut cloud = GaussianCloud::new(3);
    let tau = std::f32::consts::TAU;
    for k in 0..count {
        let t = tau * k as f32 / count.max(1) as f32;
        // (2,3) torus knot with a tube of radius 0.12 around it.
        let (p, q) = (2.0, 3.0);
        let r = 0.6 + 0.25 * (q * t).cos();
        let centre = glam::Vec3::new(r * (p * t).cos(), -0.25 * (q * t).sin(), r * (p * t).sin());
        let offset = glam::Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        ) * 0.07;
        let pos = centre + offset;
        let hue = t / tau;
        let rgb = [0.0f32, 1.0 / 3.0, 2.0 / 3.0].map(|o| 0.5 + 0.5 * (tau * (hue + o)).cos());
        let s = [
            rng.range(0.006, 0.02),
            rng.range(0.006, 0.02),
            rng.range(0.002, 0.006),
        ];
        cloud.push(
            pos.to_array(),
            rng.unit_quaternion(),
            s,
            rng.range(0.5, 1.0),
            &rgb,
        );
    }
    cloud
}
