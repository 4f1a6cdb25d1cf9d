//! Every compute pipeline of the splatting pass, built once per device. Rasterize pipelines depend
//! on the channel count (a compile-time array size in WGSL) and are built on first use per count.

use super::shader;
use std::collections::HashMap;
use std::sync::Mutex;

pub(crate) enum Binding {
    Uniform,
    Storage {
        read_only: bool,
    },
    /// Write-only r32float 2D array (the rasterizer's outputs).
    OutputTexture,
}

pub(crate) fn bind_group_layout(
    device: &wgpu::Device,
    label: &str,
    bindings: &[Binding],
) -> wgpu::BindGroupLayout {
    let entries: Vec<_> = bindings
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupLayoutEntry {
            binding: i as u32,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: match b {
                Binding::Uniform => buffer(wgpu::BufferBindingType::Uniform),
                Binding::Storage { read_only } => buffer(wgpu::BufferBindingType::Storage {
                    read_only: *read_only,
                }),
                Binding::OutputTexture => wgpu::BindingType::StorageTexture {
                    access: wgpu::StorageTextureAccess::WriteOnly,
                    format: wgpu::TextureFormat::R32Float,
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                },
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

fn compute_pipeline(
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

/// How the rasterizer maps pixels to threads. One pixel per thread is the usual GPU layout. On
/// CPU adapters (lavapipe) a load from workgroup memory costs far more than the arithmetic, so
/// each thread shades several pixels of a column and reuses every Gaussian it loads; but the
/// per-pixel accumulators then multiply, which costs more than it saves for many channels.
/// Measured on lavapipe (`guava bench splat`): 10k Gaussians, 512², 3 channels 813 → 342 ms
/// rasterizing with 4 pixels per thread; 150k, 512², 3 channels, frames of 1,453–1,501 ms with 4,
/// 1,307–1,324 with 8; 32 channels fastest with 1 (2 per thread: 8,110–8,199 ms against
/// 6,374–6,558). 16 (a whole column per thread, 1,156–1,234 ms) drew one tile of the demo
/// portrait's avatar wrong on lavapipe (rows 1–15 of a tile; cause not found), so it is not used.
/// Once up to four channels rode with the batch in workgroup memory, 8 lost its edge: 150k, 512²,
/// 3 channels rasterize in 105–118 ms with 4 and 105–115 with 8, and 4 channels (the default
/// avatars) in 92–101 ms with 4 against 174–190 with 8 (the accumulators of 8 pixels × 4
/// channels no longer fit), so 4 is the CPU layout up to four channels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RasterTuning {
    /// The same count for every channel count: 1, 2, 4, 8 or 16 (divisors of the tile side).
    PixelsPerThread(u32),
    /// 4 pixels per thread up to 4 channels, 1 above.
    Cpu,
}

impl RasterTuning {
    pub fn for_adapter(info: &wgpu::AdapterInfo) -> Self {
        if info.device_type == wgpu::DeviceType::Cpu {
            Self::Cpu
        } else {
            Self::PixelsPerThread(1)
        }
    }

    pub fn pixels_per_thread(self, channels: u32) -> u32 {
        match self {
            Self::PixelsPerThread(p) => p,
            Self::Cpu if channels <= 4 => 4,
            Self::Cpu => 1,
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
    pub tuning: RasterTuning,
    rasterize: Mutex<HashMap<u32, wgpu::ComputePipeline>>,
}

impl SplatPipelines {
    pub fn new(device: &wgpu::Device, tuning: RasterTuning) -> Self {
        if let RasterTuning::PixelsPerThread(p) = tuning {
            assert!(
                [1, 2, 4, 8, 16].contains(&p),
                "pixels per thread must divide the tile side: {p}"
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
        let m = shader::module(device, "preprocess.wgsl", shader::PREPROCESS, &[]);
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
                Binding::OutputTexture,
                Binding::OutputTexture,
            ],
        );
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
            tuning,
            rasterize: Mutex::new(HashMap::new()),
        }
    }

    pub(crate) fn rasterize(&self, device: &wgpu::Device, channels: u32) -> wgpu::ComputePipeline {
        let mut cache = self.rasterize.lock().unwrap_or_else(|e| e.into_inner());
        cache
            .entry(channels)
            .or_insert_with(|| {
                let pixels = self.tuning.pixels_per_thread(channels);
                let label = format!("Splat::rasterize[C={channels},P={pixels}]");
                let consts = [("CHANNELS", channels), ("PIXELS", pixels)];
                let m = shader::module(device, &label, shader::RASTERIZE, &consts);
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
