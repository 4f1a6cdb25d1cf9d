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
/// How the passes that read features (preprocess, rasterize) take them: f32 or f16 words of four
/// channels (shaders/features_*.wgsl), composed before the pass ([`with_features`]).
pub const FEATURES_F32: &str = include_str!("../../shaders/features_f32.wgsl");
pub const FEATURES_F16: &str = include_str!("../../shaders/features_f16.wgsl");
pub const RIG: &str = include_str!("../../shaders/rig.wgsl");
pub const PRESENT: &str = include_str!("../../shaders/present.wgsl");
pub const MESH: &str = include_str!("../../shaders/mesh.wgsl");
pub const REFINE: &str = include_str!("../../shaders/refine.wgsl");

/// `const NAME: u32 = value` lines prepended to a pass.
#[cfg(test)]
type Consts = &'static [(&'static str, u32)];

/// Every pass with the constants it needs to compile (CHANNELS = 3, PIXELS = 1 and
/// SKIP_MISSED = 0 stand in for any).
#[cfg(test)]
const ALL: &[(&str, &str, Consts)] = &[
    ("preprocess", PREPROCESS, &[]),
    ("scan", SCAN, &[]),
    ("radix_sort", RADIX_SORT, &[]),
    ("tile_keys", TILE_KEYS, &[]),
    ("tile_ranges", TILE_RANGES, &[]),
    (
        "rasterize",
        RASTERIZE_LOADS,
        &[
            ("CHANNELS", 3),
            ("PIXELS", 1),
            ("SKIP_MISSED", 0),
            ("LOOP_BUDGET", u32::MAX),
        ],
    ),
    (
        "rasterize_shuffles",
        RASTERIZE_SHUFFLES,
        &[
            ("CHANNELS", 3),
            ("PIXELS", 1),
            ("SKIP_MISSED", 1),
            ("LOOP_BUDGET", crate::render::pipelines::CPU_LOOP_BUDGET),
        ],
    ),
    ("rig", RIG, &[]),
    ("present", PRESENT, &[]),
    ("mesh", MESH, &[]),
    ("refine", REFINE, &[]),
];

/// `pass` reading features stored as `storage`.
pub fn with_features(storage: super::FeatureStorage, pass: &str) -> String {
    let features = match storage {
        super::FeatureStorage::F32 => FEATURES_F32,
        super::FeatureStorage::F16 => FEATURES_F16,
    };
    format!("{features}\n{pass}")
}

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

/// Every WGSL pass parses and validates with naga (so a broken shader fails even if no test runs
/// it), and the WGSL struct layouts equal their Rust mirrors.
#[cfg(test)]
mod tests {
    use crate::render::layout::{
        FrameUniform, GpuGaussian, PROJECTED_SIZE, PosedVertex, RigParams, ScanParams,
        SkinnedGaussian, SortPass, TRIANGLE_FRAME_SIZE, TemplateGaussian, UvGaussian,
    };
    use crate::render::present::PresentUniform;
    use crate::render::{FeatureStorage, shader};
    use wgpu::naga;

    fn module(name: &str) -> naga::Module {
        let (_, src, consts) = shader::ALL.iter().find(|(n, _, _)| *n == name).expect(name);
        validated(name, src, consts, FeatureStorage::F32)
    }

    /// A pass with its constants and feature storage (an alias and a function the passes that
    /// do not read features leave unused), parsed and validated (panics naming `label` otherwise).
    fn validated(
        label: &str,
        src: &str,
        consts: &[(&str, u32)],
        storage: FeatureStorage,
    ) -> naga::Module {
        let src = shader::with_features(storage, src);
        let module = naga::front::wgsl::parse_str(&shader::compose(&src, consts))
            .unwrap_or_else(|e| panic!("{label}: {e}"));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{label}: {e:?}"));
        module
    }

    #[test]
    fn every_pass_validates() {
        for (name, _, _) in shader::ALL {
            module(name);
        }
        // The rasterizer at the channel counts, layouts, tunings and feature storages we use and
        // the bounds we support.
        for s in [FeatureStorage::F32, FeatureStorage::F16] {
            validated("preprocess", shader::PREPROCESS, &[], s);
            for c in [1, 3, 32, 64] {
                for p in [1, 2, 4, 8] {
                    for skip in [0, 1] {
                        let consts = [
                            ("CHANNELS", c),
                            ("PIXELS", p),
                            ("SKIP_MISSED", skip),
                            ("LOOP_BUDGET", crate::render::pipelines::CPU_LOOP_BUDGET),
                        ];
                        let label = format!("rasterize {s:?} {consts:?}");
                        validated(&label, shader::RASTERIZE_LOADS, &consts, s);
                    }
                }
                for p in [1, 4] {
                    let consts = [
                        ("CHANNELS", c),
                        ("PIXELS", p),
                        ("SKIP_MISSED", 1),
                        ("LOOP_BUDGET", crate::render::pipelines::CPU_LOOP_BUDGET),
                    ];
                    let label = format!("rasterize with shuffles {s:?} {consts:?}");
                    validated(&label, shader::RASTERIZE_SHUFFLES, &consts, s);
                }
            }
        }
    }

    /// (size, member offsets) of a struct in a WGSL module.
    fn layout(module: &naga::Module, name: &str) -> (u32, Vec<u32>) {
        let ty = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("struct {name} not found"))
            .1;
        match &ty.inner {
            naga::TypeInner::Struct { members, span } => {
                (*span, members.iter().map(|m| m.offset).collect())
            }
            other => panic!("{name} is not a struct: {other:?}"),
        }
    }

    macro_rules! offsets {
        ($t:ty, $($f:ident),+) => { vec![$(std::mem::offset_of!($t, $f) as u32),+] };
    }

    #[test]
    fn wgsl_layouts_match_rust() {
        let pre = module("preprocess");
        assert_eq!(
            layout(&pre, "Frame"),
            (
                size_of::<FrameUniform>() as u32,
                offsets!(
                    FrameUniform,
                    view_from_world,
                    focal,
                    principal,
                    ewa_lim,
                    size,
                    tiles,
                    near,
                    num_gaussians,
                    pair_capacity,
                    channels,
                    low_pass,
                    _pad0,
                    _pad1,
                    _pad2
                )
            )
        );
        assert_eq!(
            layout(&pre, "Gaussian"),
            (
                size_of::<GpuGaussian>() as u32,
                offsets!(GpuGaussian, pos, opacity, rot, scale, _pad)
            )
        );
        assert_eq!(layout(&pre, "Projected").0 as u64, PROJECTED_SIZE);
        assert_eq!(
            layout(&module("scan"), "ScanParams"),
            (
                size_of::<ScanParams>() as u32,
                offsets!(ScanParams, count, num_blocks, total_index, _pad)
            )
        );
        assert_eq!(
            layout(&module("radix_sort"), "SortPass"),
            (
                size_of::<SortPass>() as u32,
                offsets!(SortPass, shift, num_blocks, count_index, _pad)
            )
        );
        assert_eq!(
            layout(&module("present"), "Present"),
            (
                size_of::<PresentUniform>() as u32,
                offsets!(
                    PresentUniform,
                    size,
                    mode,
                    srgb_target,
                    rgb_channels,
                    inv_depth_range,
                    _pad,
                    background
                )
            )
        );
        let rig = module("rig");
        assert_eq!(
            layout(&rig, "RigParams"),
            (
                size_of::<RigParams>() as u32,
                offsets!(
                    RigParams,
                    template_count,
                    uv_count,
                    triangle_count,
                    skinned_count
                )
            )
        );
        assert_eq!(
            layout(&rig, "TemplateGaussian"),
            (
                size_of::<TemplateGaussian>() as u32,
                offsets!(TemplateGaussian, rot, scale, opacity)
            )
        );
        assert_eq!(
            layout(&rig, "UvGaussian"),
            (
                size_of::<UvGaussian>() as u32,
                offsets!(
                    UvGaussian, bary, triangle, offset, opacity, rot, scale, _pad
                )
            )
        );
        assert_eq!(
            layout(&rig, "SkinnedGaussian"),
            (
                size_of::<SkinnedGaussian>() as u32,
                offsets!(
                    SkinnedGaussian,
                    vertices,
                    weights,
                    offset,
                    opacity,
                    rot,
                    scale,
                    _pad
                )
            )
        );
        assert_eq!(layout(&rig, "TriangleFrame").0 as u64, TRIANGLE_FRAME_SIZE);
        {
            use crate::refine::wgsl::OpParams;
            let (size, offsets) = layout(&module("refine"), "Op");
            assert_eq!(size as usize, size_of::<OpParams>());
            let rust = offsets!(
                OpParams,
                in_c,
                in_h,
                in_w,
                out_c,
                out_h,
                out_w,
                kernel_h,
                kernel_w,
                stride_h,
                stride_w,
                pad_top,
                pad_left,
                kind,
                src_channel,
                dst_channel,
                lo,
                hi,
                scale_h,
                scale_w
            );
            assert_eq!(offsets[..rust.len()], rust[..]);
            assert_eq!(offsets[rust.len()], 80, "the shader's _pad");
        }
        assert_eq!(
            layout(&rig, "PosedVertex"),
            (
                size_of::<PosedVertex>() as u32,
                offsets!(PosedVertex, position, skin)
            )
        );
    }
}
