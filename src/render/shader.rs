//! WGSL sources, compiled into the binary, and the one way they are composed: `const` overrides,
//! then shaders/common.wgsl, then the pass. Every pass is built through [`compose`].

pub const COMMON: &str = include_str!("../../shaders/common.wgsl");
pub const PREPROCESS: &str = include_str!("../../shaders/preprocess.wgsl");
pub const SCAN: &str = include_str!("../../shaders/scan.wgsl");
pub const RADIX_SORT: &str = include_str!("../../shaders/radix_sort.wgsl");
pub const TILE_KEYS: &str = include_str!("../../shaders/tile_keys.wgsl");
pub const TILE_RANGES: &str = include_str!("../../shaders/tile_ranges.wgsl");
/// The rasterizer with each way its threads read a batched Gaussian (shaders/rasterize_fetch_*.wgsl):
/// every thread loading all of it, or the 8 lanes of a subgroup loading parts and exchanging them.
pub const RASTERIZE_LOADS: &str = concat!(
    include_str!("../../shaders/rasterize_fetch_loads.wgsl"),
    include_str!("../../shaders/rasterize.wgsl")
);
pub const RASTERIZE_SHUFFLES: &str = concat!(
    include_str!("../../shaders/rasterize_fetch_shuffles.wgsl"),
    include_str!("../../shaders/rasterize.wgsl")
);
pub const RIG: &str = include_str!("../../shaders/rig.wgsl");
pub const PRESENT: &str = include_str!("../../shaders/present.wgsl");
pub const MESH: &str = include_str!("../../shaders/mesh.wgsl");

/// `const NAME: u32 = value` lines prepended to a pass.
pub type Consts = &'static [(&'static str, u32)];

/// Every pass with the constants it needs to compile (CHANNELS = 3, PIXELS = 1 and
/// SKIP_MISSED = 0 stand in for any).
pub const ALL: &[(&str, &str, Consts)] = &[
    ("preprocess", PREPROCESS, &[]),
    ("scan", SCAN, &[]),
    ("radix_sort", RADIX_SORT, &[]),
    ("tile_keys", TILE_KEYS, &[]),
    ("tile_ranges", TILE_RANGES, &[]),
    (
        "rasterize",
        RASTERIZE_LOADS,
        &[("CHANNELS", 3), ("PIXELS", 1), ("SKIP_MISSED", 0)],
    ),
    (
        "rasterize_shuffles",
        RASTERIZE_SHUFFLES,
        &[("CHANNELS", 3), ("PIXELS", 1), ("SKIP_MISSED", 1)],
    ),
    ("rig", RIG, &[]),
    ("present", PRESENT, &[]),
    ("mesh", MESH, &[]),
];

pub fn compose(pass: &str, consts: &[(&str, u32)]) -> String {
    let mut out = String::new();
    for (name, value) in consts {
        out.push_str(&format!("const {name}: u32 = {value}u;\n"));
    }
    out.push_str(COMMON);
    out.push('\n');
    out.push_str(pass);
    out
}

pub fn module(
    device: &wgpu::Device,
    label: &str,
    pass: &str,
    consts: &[(&str, u32)],
) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(compose(pass, consts).into()),
    })
}
