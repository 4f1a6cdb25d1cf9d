//! Benchmarks behind `guava bench …`: each prints a table of medians and the hardware it ran on.

mod body;
mod fidelity;
mod frame;
mod guava_mode;
mod reconstruct;
mod refiner;
mod splat;
mod track;

pub use body::{BodyBenchArgs, body, cpu_name};
pub use fidelity::{FidelityBenchArgs, fidelity};
pub use frame::{FrameBenchArgs, frame};
pub use guava_mode::{GuavaBenchArgs, guava};
pub use reconstruct::{ReconstructBenchArgs, reconstruct};
pub use refiner::{RefinerBenchArgs, refiner};
pub use splat::{SplatBenchArgs, splat};
pub use track::{TrackBenchArgs, track};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}
