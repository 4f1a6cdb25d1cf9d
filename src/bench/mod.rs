//! Benchmarks behind `guava bench …`: each prints a table of medians and the hardware it ran on.

mod body;
mod guava;
mod reconstruct;
mod splat;

pub use body::{BodyBenchArgs, body};
pub use guava::{GuavaBenchArgs, guava};
pub use reconstruct::{ReconstructBenchArgs, portrait_placed, reconstruct};
pub use splat::{SplatBenchArgs, splat};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}
