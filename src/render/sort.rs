//! Host side of shaders/radix_sort.wgsl: a stable LSD sort of (u32 key, u32 value) pairs on the GPU,
//! 4 bits per pass, ping-ponging between the A and B buffers. The pass count is rounded up to even
//! so the result always ends in A. The live element count is read on the GPU from a buffer;
//! dispatches are sized for the buffers' capacity and idle blocks exit at once.

use super::layout::SortPass;
use super::pipelines::{SplatPipelines, dispatch_1d};
use super::scan::{PrefixScan, entry};
use wgpu::util::DeviceExt;

pub const SORT_BLOCK: u32 = 2048;
const RADIX: u32 = 16;
const BITS_PER_PASS: u32 = 4;
/// Uniform offsets must be 256-byte aligned.
const UNIFORM_STRIDE: u64 = 256;

pub(crate) struct SortBuffers<'a> {
    /// The live element count is `count[count_index]`.
    pub count: &'a wgpu::Buffer,
    pub count_index: u32,
    pub keys_a: &'a wgpu::Buffer,
    pub vals_a: &'a wgpu::Buffer,
    pub keys_b: &'a wgpu::Buffer,
    pub vals_b: &'a wgpu::Buffer,
}

pub(crate) struct RadixSort {
    passes: Vec<wgpu::BindGroup>,
    hist_scan: PrefixScan,
    num_blocks: u32,
}

/// Passes needed for keys below `2^key_bits`, rounded up to even.
pub fn pass_count(key_bits: u32) -> u32 {
    key_bits.div_ceil(BITS_PER_PASS).next_multiple_of(2).max(2)
}

impl RadixSort {
    pub fn new(
        device: &wgpu::Device,
        pipes: &SplatPipelines,
        label: &str,
        buffers: SortBuffers<'_>,
        capacity: u32,
        key_bits: u32,
    ) -> Self {
        let num_blocks = capacity.div_ceil(SORT_BLOCK).max(1);
        let passes = pass_count(key_bits);
        let mut uniforms = vec![0u8; (passes as u64 * UNIFORM_STRIDE) as usize];
        for p in 0..passes {
            let at = (p as u64 * UNIFORM_STRIDE) as usize;
            let params = SortPass {
                shift: p * BITS_PER_PASS,
                num_blocks,
                count_index: buffers.count_index,
                _pad: 0,
            };
            uniforms[at..at + size_of::<SortPass>()].copy_from_slice(bytemuck::bytes_of(&params));
        }
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(&format!("{label}::passes")),
            contents: &uniforms,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let hist = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(&format!("{label}::hist")),
            size: (RADIX * num_blocks) as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let hist_total = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(&format!("{label}::hist_total")),
            size: 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let hist_scan = PrefixScan::new(
            device,
            pipes,
            &format!("{label}::hist_scan"),
            &hist,
            RADIX * num_blocks,
            &hist_total,
            0,
        );
        let b = &buffers;
        let passes = (0..passes)
            .map(|p| {
                let (ki, vi, ko, vo) = if p % 2 == 0 {
                    (b.keys_a, b.vals_a, b.keys_b, b.vals_b)
                } else {
                    (b.keys_b, b.vals_b, b.keys_a, b.vals_a)
                };
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(&format!("{label}::pass{p}")),
                    layout: &pipes.sort_layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                buffer: &uniform,
                                offset: p as u64 * UNIFORM_STRIDE,
                                size: wgpu::BufferSize::new(size_of::<SortPass>() as u64),
                            }),
                        },
                        entry(1, b.count),
                        entry(2, ki),
                        entry(3, vi),
                        entry(4, ko),
                        entry(5, vo),
                        entry(6, &hist),
                    ],
                })
            })
            .collect();
        Self {
            passes,
            hist_scan,
            num_blocks,
        }
    }

    pub fn encode(&self, pipes: &SplatPipelines, pass: &mut wgpu::ComputePass<'_>) {
        for bind_group in &self.passes {
            pass.set_bind_group(0, bind_group, &[]);
            pass.set_pipeline(&pipes.sort_histogram);
            dispatch_1d(pass, self.num_blocks);
            self.hist_scan.encode(pipes, pass);
            pass.set_bind_group(0, bind_group, &[]);
            pass.set_pipeline(&pipes.sort_scatter);
            dispatch_1d(pass, self.num_blocks);
        }
    }
}
