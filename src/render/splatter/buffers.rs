//! The splatting pass's buffers and bind groups: what is allocated per Gaussian of capacity, per
//! view (tile pairs, ranges, output layers), and the bind groups that tie them to the pipelines,
//! rebuilt only when a buffer is reallocated.

use super::Splatter;
use crate::camera::Camera;
use crate::render::FeatureStorage;
use crate::render::layout::{GpuGaussian, PROJECTED_SIZE};
use crate::render::pipelines::{AUX_FORMAT, FEATURES_FORMAT};
use crate::render::scan::{PrefixScan, entry};
use crate::render::sort::{RadixSort, SortBuffers};
use crate::render::splatter::{array_view, feature_bytes, feature_stride};

/// Per-Gaussian buffers, sized by capacity.
pub(super) struct CloudBuffers {
    pub(super) capacity: u32,
    pub(super) channels: u32,
    pub(super) gaussians: wgpu::Buffer,
    pub(super) features: wgpu::Buffer,
    pub(super) projected: wgpu::Buffer,
    pub(super) depth_keys: wgpu::Buffer,
    pub(super) depth_order: wgpu::Buffer,
    pub(super) depth_keys_tmp: wgpu::Buffer,
    pub(super) depth_order_tmp: wgpu::Buffer,
    pub(super) touched: wgpu::Buffer,
    pub(super) pair_offsets: wgpu::Buffer,
}

/// Per-view buffers: tile pairs, ranges, the output layers.
pub(super) struct ViewBuffers {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) channels: u32,
    pub(super) pair_capacity: u32,
    pub(super) tile_keys: wgpu::Buffer,
    pub(super) tile_vals: wgpu::Buffer,
    pub(super) tile_keys_tmp: wgpu::Buffer,
    pub(super) tile_vals_tmp: wgpu::Buffer,
    pub(super) ranges: wgpu::Buffer,
    pub(super) out_features: wgpu::Texture,
    pub(super) out_aux: wgpu::Texture,
    pub(super) background: wgpu::Buffer,
}

/// Every bind group of one frame's passes, made when buffers change.
pub(super) struct Bindings {
    pub(super) preprocess: wgpu::BindGroup,
    pub(super) depth_sort: RadixSort,
    pub(super) pair_scan: PrefixScan,
    pub(super) keys: wgpu::BindGroup,
    pub(super) tile_sort: RadixSort,
    pub(super) ranges: wgpu::BindGroup,
    pub(super) rasterize: wgpu::BindGroup,
    pub(super) rasterize_pipeline: wgpu::ComputePipeline,
}

pub(super) fn storage(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

pub(super) fn output_texture(
    device: &wgpu::Device,
    label: &str,
    camera: &Camera,
    format: wgpu::TextureFormat,
    layers: u32,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: camera.width,
            height: camera.height,
            depth_or_array_layers: layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

impl Splatter {
    pub(super) fn alloc_cloud(
        device: &wgpu::Device,
        capacity: u32,
        channels: u32,
        features_as: FeatureStorage,
    ) -> CloudBuffers {
        let n = capacity as u64;
        CloudBuffers {
            capacity,
            channels,
            gaussians: storage(
                device,
                "Splat::gaussians",
                n * size_of::<GpuGaussian>() as u64,
            ),
            features: storage(
                device,
                "Splat::features",
                n * feature_bytes(channels, features_as),
            ),
            projected: storage(device, "Splat::projected", n * PROJECTED_SIZE),
            depth_keys: storage(device, "Splat::depth_keys", n * 4),
            depth_order: storage(device, "Splat::depth_order", n * 4),
            depth_keys_tmp: storage(device, "Splat::depth_keys_tmp", n * 4),
            depth_order_tmp: storage(device, "Splat::depth_order_tmp", n * 4),
            touched: storage(device, "Splat::touched", n * 4),
            pair_offsets: storage(device, "Splat::pair_offsets", n * 4),
        }
    }

    pub(super) fn alloc_view(
        device: &wgpu::Device,
        camera: &Camera,
        channels: u32,
        pair_capacity: u32,
    ) -> ViewBuffers {
        let (tx, ty) = crate::render::tile_grid(camera);
        let pairs = pair_capacity as u64;
        ViewBuffers {
            width: camera.width,
            height: camera.height,
            channels,
            pair_capacity,
            tile_keys: storage(device, "Splat::tile_keys", pairs * 4),
            tile_vals: storage(device, "Splat::tile_vals", pairs * 4),
            tile_keys_tmp: storage(device, "Splat::tile_keys_tmp", pairs * 4),
            tile_vals_tmp: storage(device, "Splat::tile_vals_tmp", pairs * 4),
            ranges: storage(device, "Splat::tile_ranges", tx as u64 * ty as u64 * 8),
            out_features: output_texture(
                device,
                "Splat::out_features",
                camera,
                FEATURES_FORMAT,
                feature_stride(channels) / 4,
            ),
            out_aux: output_texture(device, "Splat::out_aux", camera, AUX_FORMAT, 1),
            background: storage(
                device,
                "Splat::background",
                feature_stride(channels) as u64 * 4,
            ),
        }
    }

    pub(super) fn bind(&self, device: &wgpu::Device, camera: &Camera) -> Bindings {
        let (Some(c), Some(v)) = (&self.cloud, &self.view) else {
            unreachable!("bind is called after both buffer sets exist");
        };
        let pipes = &*self.pipes;
        let group = |label: &str, layout: &wgpu::BindGroupLayout, buffers: &[&wgpu::Buffer]| {
            let entries: Vec<_> = buffers
                .iter()
                .enumerate()
                .map(|(i, b)| entry(i as u32, b))
                .collect();
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout,
                entries: &entries,
            })
        };
        let preprocess = group(
            "Splat::preprocess",
            &pipes.preprocess_layout,
            &[
                &self.frame,
                &c.gaussians,
                &c.features,
                &c.projected,
                &c.depth_keys,
                &c.depth_order,
                &c.touched,
                &self.stats,
            ],
        );
        let depth_sort = RadixSort::new(
            device,
            pipes,
            "Splat::depth_sort",
            SortBuffers {
                count: &self.depth_count,
                count_index: 0,
                keys_a: &c.depth_keys,
                vals_a: &c.depth_order,
                keys_b: &c.depth_keys_tmp,
                vals_b: &c.depth_order_tmp,
            },
            c.capacity,
            32,
        );
        // gather_counts and emit_keys read the depth order where the sort left it.
        let depth_order = depth_sort.sorted(&c.depth_order, &c.depth_order_tmp);
        let pair_scan = PrefixScan::new(
            device,
            pipes,
            "Splat::pair_scan",
            &c.pair_offsets,
            c.capacity,
            &self.pair_count,
            0,
        );
        let keys = group(
            "Splat::tile_keys",
            &pipes.keys_layout,
            &[
                &self.frame,
                depth_order,
                &c.touched,
                &c.pair_offsets,
                &c.projected,
                &v.tile_keys,
                &v.tile_vals,
                &self.pair_count,
                &self.stats,
            ],
        );
        let (tx, ty) = crate::render::tile_grid(camera);
        let tile_bits = 32 - (tx * ty).saturating_sub(1).leading_zeros();
        let tile_sort = RadixSort::new(
            device,
            pipes,
            "Splat::tile_sort",
            SortBuffers {
                count: &self.pair_count,
                count_index: 1,
                keys_a: &v.tile_keys,
                vals_a: &v.tile_vals,
                keys_b: &v.tile_keys_tmp,
                vals_b: &v.tile_vals_tmp,
            },
            v.pair_capacity,
            tile_bits,
        );
        // The tile sort's pass count follows the tile count; read its result where it landed.
        let (sorted_keys, sorted_vals) = tile_sort.sorted(
            (&v.tile_keys, &v.tile_vals),
            (&v.tile_keys_tmp, &v.tile_vals_tmp),
        );
        let ranges = group(
            "Splat::tile_ranges",
            &pipes.ranges_layout,
            &[sorted_keys, &self.pair_count, &v.ranges],
        );
        let features_view = array_view(&v.out_features);
        let aux_view = array_view(&v.out_aux);
        let rasterize = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("Splat::rasterize"),
            layout: &pipes.rasterize_layout,
            entries: &[
                entry(0, &self.frame),
                entry(1, &v.ranges),
                entry(2, sorted_vals),
                entry(3, &c.projected),
                entry(4, &c.features),
                entry(5, &v.background),
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::TextureView(&features_view),
                },
                wgpu::BindGroupEntry {
                    binding: 7,
                    resource: wgpu::BindingResource::TextureView(&aux_view),
                },
                entry(8, &self.stats),
            ],
        });
        Bindings {
            preprocess,
            depth_sort,
            pair_scan,
            keys,
            tile_sort,
            ranges,
            rasterize,
            rasterize_pipeline: pipes.rasterize(device, c.channels),
        }
    }
}
