//! Every compute pipeline of the splatting pass, built once per device. Rasterize pipelines depend
//! on the channel count (a compile-time array size in WGSL) and are built on first use per count.

use super::shader;
use std::collections::HashMap;
use std::sync::Mutex;

/// The rasterizer's outputs: the channels four to a texel (shaders/rasterize.wgsl), and alpha
/// with inverse depth. The formats of its `texture_storage_2d_array` declarations.
pub(crate) const FEATURES_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
pub(crate) const AUX_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;

#[derive(Clone, Copy)]
pub(crate) enum Binding {
    Uniform,
    Storage {
        read_only: bool,
    },
    /// A write-only 2D array of this format (the rasterizer's outputs).
    OutputTexture(wgpu::TextureFormat),
    /// A float 2D array read with `textureLoad` (the splat output, read by the refiner).
    InputTexture,
    /// An unused binding number (entry points of one shader module share its numbering).
    Skip,
}

pub(crate) fn bind_group_layout(
    device: &wgpu::Device,
    label: &str,
    bindings: &[Binding],
) -> wgpu::BindGroupLayout {
    let entries: Vec<_> = bindings
        .iter()
        .enumerate()
        .filter(|(_, b)| !matches!(b, Binding::Skip))
        .map(|(i, b)| wgpu::BindGroupLayoutEntry {
            binding: i as u32,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: match b {
                Binding::Uniform => buffer(wgpu::BufferBindingType::Uniform),
                Binding::Storage { read_only } => buffer(wgpu::BufferBindingType::Storage {
                    read_only: *read_only,
                }),
                Binding::OutputTexture(format) => wgpu::BindingType::StorageTexture {
                    access: wgpu::StorageTextureAccess::WriteOnly,
                    format: *format,
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                },
                Binding::InputTexture => wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                Binding::Skip => unreachable!("filtered out"),
            },
            count: None,
        })
        .collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    })
}

fn buffer(ty: wgpu::BufferBindingType) -> wgpu::BindingType {
    wgpu::BindingType::Buffer {
        ty,
        has_dynamic_offset: false,
        min_binding_size: None,
    }
}

pub(crate) fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    module: &wgpu::ShaderModule,
    entry: &str,
) -> wgpu::ComputePipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// How the rasterizer maps pixels to threads and walks a tile's batched Gaussians
/// (shaders/rasterize.wgsl). One pixel per thread, every thread reading every Gaussian, is the
/// usual GPU layout: a warp skips the blending none of its threads needs.
///
/// On a CPU adapter (lavapipe) a branch skips nothing: each SIMD row of 8 threads runs the loop
/// body for every Gaussian with its lanes masked, and a load from memory costs far more than the
/// arithmetic. So there each block of 8 threads walks only the Gaussians that reach one of its
/// pixels (a bit mask per block, found once per batch), and each thread shades 4 pixels up to 16
/// channels, 2 above, reusing every Gaussian it loads (with more, llvmpipe no longer keeps the
/// accumulators in registers). Measured on lavapipe, 150k Gaussians at 512² (`guava bench
/// splat`, side by side with the layout before, which had no skipping and gave each thread pixels
/// of a column spaced apart): rasterizing 32 channels ×0.51–0.53, 3 channels ×0.57–0.63; one pixel
/// per thread rasterized 3 channels 1.35–2.4× slower than 4 (README, Performance).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RasterTuning {
    /// This many pixels per thread (1, 2, 4 or 8), every thread reading every batched Gaussian.
    Lockstep(u32),
    /// CPU adapters: 4 pixels per thread up to 16 channels, 2 above, skipping Gaussians per block.
    /// With `shuffles` each block is one subgroup whose 8 lanes load different words of a Gaussian
    /// and exchange them (shaders/rasterize_fetch_shuffles.wgsl): llvmpipe loads memory one lane
    /// at a time, so this cuts a Gaussian's loads 8-fold (rasterizing ×0.48–0.50 at 32 channels,
    /// ×0.71–0.79 at 3 on lavapipe, README).
    Cpu { shuffles: bool },
}

/// The rasterizer's loop budget on CPU adapters: under llvmpipe's 65,535 iterations, past which
/// it silently leaves every loop of the invocation (`LP_MAX_TGSI_LOOP_ITERATIONS` in Mesa's
/// gallivm).
pub const CPU_LOOP_BUDGET: u32 = 60_000;

impl RasterTuning {
    /// The layout for a device: lockstep on GPUs; on CPU adapters skipping, with shuffles where
    /// the device has subgroups of exactly a block's 8 lanes.
    pub fn for_device(info: &wgpu::AdapterInfo, features: wgpu::Features) -> Self {
        if info.device_type == wgpu::DeviceType::Cpu {
            Self::Cpu {
                shuffles: Self::shuffles_fit(info, features),
            }
        } else {
            Self::Lockstep(1)
        }
    }

    /// Whether blocks of 8 threads can be subgroups: the SUBGROUP feature and 8 lanes, no more or
    /// fewer (lavapipe on AVX; 4 lanes with SSE only).
    pub fn shuffles_fit(info: &wgpu::AdapterInfo, features: wgpu::Features) -> bool {
        features.contains(wgpu::Features::SUBGROUP)
            && info.subgroup_min_size == 8
            && info.subgroup_max_size == 8
    }

    pub fn pixels_per_thread(self, channels: u32) -> u32 {
        match self {
            Self::Lockstep(p) => p,
            // Measured on lavapipe, 10k Gaussians at 512² (`guava bench splat`), rasterize time
            // against 1 pixel a thread: 32 channels 0.67× at 2 pixels but 1.8× at 4 (llvmpipe no
            // longer keeps 32 accumulators in registers); 64 channels 0.8× at 2; 8 and 16
            // channels 0.5× at 4 (0.8–0.9× of 2).
            Self::Cpu { .. } if channels <= 16 => 4,
            Self::Cpu { .. } => 2,
        }
    }

    pub fn skips_missed(self) -> bool {
        matches!(self, Self::Cpu { .. })
    }

    /// Loop iterations the rasterizer lets one block run (`LOOP_BUDGET`, shaders/rasterize.wgsl):
    /// [`CPU_LOOP_BUDGET`] on CPU adapters; none on GPUs.
    pub fn loop_budget(self) -> u32 {
        match self {
            Self::Cpu { .. } => CPU_LOOP_BUDGET,
            Self::Lockstep(_) => u32::MAX,
        }
    }

    fn shuffles(self) -> bool {
        matches!(self, Self::Cpu { shuffles: true })
    }
}

/// How each Gaussian's feature channels are stored on the GPU: f32, or f16 (half the memory
/// and bandwidth; about 3 significant digits, within the f64 reference's 1e-3 bound for
/// features in [0, 1]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FeatureStorage {
    #[default]
    F32,
    F16,
}

impl FeatureStorage {
    /// Bytes of one channel.
    pub fn channel_bytes(self) -> u64 {
        match self {
            Self::F32 => 4,
            Self::F16 => 2,
        }
    }
}

pub struct SplatPipelines {
    pub(crate) preprocess_layout: wgpu::BindGroupLayout,
    pub(crate) preprocess: wgpu::ComputePipeline,
    pub(crate) scan_layout: wgpu::BindGroupLayout,
    pub(crate) scan_reduce: wgpu::ComputePipeline,
    pub(crate) scan_sums: wgpu::ComputePipeline,
    pub(crate) scan_blocks: wgpu::ComputePipeline,
    pub(crate) sort_layout: wgpu::BindGroupLayout,
    pub(crate) sort_histogram: wgpu::ComputePipeline,
    pub(crate) sort_scatter: wgpu::ComputePipeline,
    pub(crate) keys_layout: wgpu::BindGroupLayout,
    pub(crate) gather_counts: wgpu::ComputePipeline,
    pub(crate) clamp_pairs: wgpu::ComputePipeline,
    pub(crate) emit_keys: wgpu::ComputePipeline,
    pub(crate) ranges_layout: wgpu::BindGroupLayout,
    pub(crate) tile_ranges: wgpu::ComputePipeline,
    pub(crate) rasterize_layout: wgpu::BindGroupLayout,
    pub(crate) rig_layout: wgpu::BindGroupLayout,
    pub(crate) rig_frames: wgpu::ComputePipeline,
    pub(crate) rig_template: wgpu::ComputePipeline,
    pub(crate) rig_uv: wgpu::ComputePipeline,
    pub(crate) rig_skinned: wgpu::ComputePipeline,
    pub tuning: RasterTuning,
    pub storage: FeatureStorage,
    rasterize: Mutex<HashMap<u32, wgpu::ComputePipeline>>,
}

impl SplatPipelines {
    pub fn new(device: &wgpu::Device, tuning: RasterTuning) -> Self {
        Self::with_storage(device, tuning, FeatureStorage::F32)
    }

    pub fn with_storage(
        device: &wgpu::Device,
        tuning: RasterTuning,
        storage: FeatureStorage,
    ) -> Self {
        if let RasterTuning::Lockstep(p) = tuning {
            assert!(
                [1, 2, 4, 8].contains(&p),
                "pixels per thread must be 1, 2, 4 or 8 (a block of 8 threads is 4 × 2·p pixels \
                 of the 16-pixel tile): {p}"
            );
        }
        use Binding::{Storage, Uniform};
        let ro = Storage { read_only: true };
        let rw = || Storage { read_only: false };

        let preprocess_layout = bind_group_layout(
            device,
            "Splat::preprocess",
            &[
                Uniform,
                ro,
                Storage { read_only: true },
                rw(),
                rw(),
                rw(),
                rw(),
                rw(),
            ],
        );
        let source = shader::with_features(storage, shader::PREPROCESS);
        let m = shader::module(device, "preprocess.wgsl", &source, &[]);
        let preprocess =
            compute_pipeline(device, "Splat::preprocess", &preprocess_layout, &m, "main");

        let scan_layout = bind_group_layout(device, "Splat::scan", &[Uniform, rw(), rw(), rw()]);
        let m = shader::module(device, "scan.wgsl", shader::SCAN, &[]);
        let scan_reduce =
            compute_pipeline(device, "Splat::scan_reduce", &scan_layout, &m, "reduce");
        let scan_sums = compute_pipeline(device, "Splat::scan_sums", &scan_layout, &m, "scan_sums");
        let scan_blocks = compute_pipeline(
            device,
            "Splat::scan_blocks",
            &scan_layout,
            &m,
            "scan_blocks",
        );

        let sort_layout = bind_group_layout(
            device,
            "Splat::radix_sort",
            &[
                Uniform,
                Storage { read_only: true },
                Storage { read_only: true },
                Storage { read_only: true },
                rw(),
                rw(),
                rw(),
            ],
        );
        let m = shader::module(device, "radix_sort.wgsl", shader::RADIX_SORT, &[]);
        let sort_histogram = compute_pipeline(
            device,
            "Splat::sort_histogram",
            &sort_layout,
            &m,
            "histogram",
        );
        let sort_scatter =
            compute_pipeline(device, "Splat::sort_scatter", &sort_layout, &m, "scatter");

        let keys_layout = bind_group_layout(
            device,
            "Splat::tile_keys",
            &[
                Uniform,
                Storage { read_only: true },
                Storage { read_only: true },
                rw(),
                Storage { read_only: true },
                rw(),
                rw(),
                rw(),
                rw(),
            ],
        );
        let m = shader::module(device, "tile_keys.wgsl", shader::TILE_KEYS, &[]);
        let gather_counts = compute_pipeline(
            device,
            "Splat::gather_counts",
            &keys_layout,
            &m,
            "gather_counts",
        );
        let clamp_pairs = compute_pipeline(
            device,
            "Splat::clamp_pairs",
            &keys_layout,
            &m,
            "clamp_pairs",
        );
        let emit_keys = compute_pipeline(device, "Splat::emit_keys", &keys_layout, &m, "emit_keys");

        let ranges_layout = bind_group_layout(
            device,
            "Splat::tile_ranges",
            &[
                Storage { read_only: true },
                Storage { read_only: true },
                rw(),
            ],
        );
        let m = shader::module(device, "tile_ranges.wgsl", shader::TILE_RANGES, &[]);
        let tile_ranges =
            compute_pipeline(device, "Splat::tile_ranges", &ranges_layout, &m, "main");

        let rasterize_layout = bind_group_layout(
            device,
            "Splat::rasterize",
            &[
                Uniform,
                Storage { read_only: true },
                Storage { read_only: true },
                Storage { read_only: true },
                Storage { read_only: true },
                Storage { read_only: true },
                Binding::OutputTexture(FEATURES_FORMAT),
                Binding::OutputTexture(AUX_FORMAT),
                rw(),
            ],
        );
        let rig_layout = bind_group_layout(
            device,
            "Rig",
            &[
                Uniform,
                Storage { read_only: true },
                Storage { read_only: true },
                Storage { read_only: true },
                Storage { read_only: true },
                rw(),
                rw(),
                Storage { read_only: true },
            ],
        );
        let m = shader::module(device, "rig.wgsl", shader::RIG, &[]);
        let rig_frames = compute_pipeline(device, "Rig::frames", &rig_layout, &m, "frames_main");
        let rig_template =
            compute_pipeline(device, "Rig::template", &rig_layout, &m, "template_main");
        let rig_uv = compute_pipeline(device, "Rig::uv", &rig_layout, &m, "uv_main");
        let rig_skinned = compute_pipeline(device, "Rig::skinned", &rig_layout, &m, "skinned_main");
        Self {
            preprocess_layout,
            preprocess,
            scan_layout,
            scan_reduce,
            scan_sums,
            scan_blocks,
            sort_layout,
            sort_histogram,
            sort_scatter,
            keys_layout,
            gather_counts,
            clamp_pairs,
            emit_keys,
            ranges_layout,
            tile_ranges,
            rasterize_layout,
            rig_layout,
            rig_frames,
            rig_template,
            rig_uv,
            rig_skinned,
            tuning,
            storage,
            rasterize: Mutex::new(HashMap::new()),
        }
    }

    pub(crate) fn rasterize(&self, device: &wgpu::Device, channels: u32) -> wgpu::ComputePipeline {
        let mut cache = self.rasterize.lock().unwrap_or_else(|e| e.into_inner());
        cache
            .entry(channels)
            .or_insert_with(|| {
                let pixels = self.tuning.pixels_per_thread(channels);
                let skip = u32::from(self.tuning.skips_missed());
                let shuffles = self.tuning.shuffles();
                let label = format!(
                    "Splat::rasterize[C={channels},P={pixels},skip={skip},shuffles={shuffles},{:?}]",
                    self.storage
                );
                let consts = [
                    ("CHANNELS", channels),
                    ("PIXELS", pixels),
                    ("SKIP_MISSED", skip),
                    ("LOOP_BUDGET", self.tuning.loop_budget()),
                ];
                let source = if shuffles {
                    shader::RASTERIZE_SHUFFLES
                } else {
                    shader::RASTERIZE_LOADS
                };
                let source = shader::with_features(self.storage, source);
                let m = shader::module(device, &label, &source, &consts);
                compute_pipeline(device, &label, &self.rasterize_layout, &m, "main")
            })
            .clone()
    }
}

/// Dispatches `groups` workgroups, folding counts above the per-dimension limit into y
/// (the shaders recover the flat index with `flat_id`).
pub(crate) fn dispatch_1d(pass: &mut wgpu::ComputePass<'_>, groups: u32) {
    if groups == 0 {
        return;
    }
    const MAX: u32 = 65535;
    let x = groups.min(MAX);
    pass.dispatch_workgroups(x, groups.div_ceil(x), 1);
}
