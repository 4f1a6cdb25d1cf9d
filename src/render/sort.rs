//! Host side of shaders/radix_sort.wgsl: a stable LSD sort of (u32 key, u32 value) pairs on the GPU,
//! 5 bits per pass, ping-ponging between the A and B buffers; after an odd number of passes the
//! result is in B ([`RadixSort::sorted`]). The live element count is read on the GPU from a buffer;
//! dispatches are sized for the buffers' capacity and idle blocks exit at once.

use super::layout::SortPass;
use super::pipelines::{SplatPipelines, dispatch_1d};
use super::scan::{PrefixScan, entry};
use wgpu::util::DeviceExt;

pub const SORT_BLOCK: u32 = 2048;
const RADIX: u32 = 32;
const BITS_PER_PASS: u32 = 5;
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

/// Passes needed for keys below `2^key_bits` (at least one).
pub fn pass_count(key_bits: u32) -> u32 {
    key_bits.div_ceil(BITS_PER_PASS).max(1)
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

    /// Whichever of the A and B buffers (or anything bound to them) holds the sorted pairs: B after
    /// an odd number of passes. The pass count follows the key bits, so callers never assume one.
    pub fn sorted<T>(&self, a: T, b: T) -> T {
        if self.passes.len() % 2 == 1 { b } else { a }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gaussians::synthetic::Rng;
    use crate::gpu::GpuContext;
    use crate::render::readback::read_buffers;

    fn buffer(device: &wgpu::Device, data: &[u32]) -> wgpu::Buffer {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("test"),
            contents: bytemuck::cast_slice(if data.is_empty() { &[0u32] } else { data }),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
        })
    }

    /// Sorts on the GPU with `capacity` ≥ keys.len() (the live count is keys.len()).
    fn gpu_sort(
        gpu: &GpuContext,
        keys: &[u32],
        capacity: u32,
        key_bits: u32,
    ) -> (Vec<u32>, Vec<u32>) {
        let (device, queue) = (&gpu.device, &gpu.queue);
        let pipes = SplatPipelines::new(device, crate::render::RasterTuning::Lockstep(1));
        let mut padded = keys.to_vec();
        padded.resize(capacity as usize, 0xdead_beef);
        let vals: Vec<u32> = (0..capacity).collect();
        let count = buffer(device, &[keys.len() as u32]);
        let (ka, va) = (buffer(device, &padded), buffer(device, &vals));
        let (kb, vb) = (buffer(device, &padded), buffer(device, &vals));
        let sort = RadixSort::new(
            device,
            &pipes,
            "test",
            SortBuffers {
                count: &count,
                count_index: 0,
                keys_a: &ka,
                vals_a: &va,
                keys_b: &kb,
                vals_b: &vb,
            },
            capacity,
            key_bits,
        );
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            sort.encode(&pipes, &mut pass);
        }
        queue.submit([encoder.finish()]);
        let n = keys.len() as u64 * 4;
        if n == 0 {
            return (Vec::new(), Vec::new());
        }
        let (k, v) = sort.sorted((&ka, &va), (&kb, &vb));
        let out = read_buffers(device, queue, &[(k, n), (v, n)]);
        (
            bytemuck::cast_slice(&out[0]).to_vec(),
            bytemuck::cast_slice(&out[1]).to_vec(),
        )
    }

    fn check(gpu: &GpuContext, keys: Vec<u32>, capacity: u32, key_bits: u32) {
        let mut expected: Vec<(u32, u32)> = keys.iter().copied().zip(0..).collect();
        expected.sort_by_key(|(k, _)| *k); // stable: equal keys keep index order
        let (k, v) = gpu_sort(gpu, &keys, capacity, key_bits);
        let got: Vec<(u32, u32)> = k.into_iter().zip(v).collect();
        assert_eq!(got.len(), expected.len());
        if let Some(i) = (0..got.len()).find(|&i| got[i] != expected[i]) {
            panic!(
                "n={} first mismatch at {i}: {:?} vs {:?}",
                keys.len(),
                got[i],
                expected[i]
            );
        }
    }

    #[test]
    fn sorts_stably_against_a_cpu_sort() {
        let gpu = GpuContext::headless().expect("adapter");
        let mut rng = Rng::new(5);
        check(&gpu, vec![], 16, 32);
        check(&gpu, vec![7], 16, 32);
        for n in [2047usize, 2048, 2049, 100_000] {
            // Few distinct keys: stability is what is being checked.
            let keys: Vec<u32> = (0..n).map(|_| (rng.next_u64() % 37) as u32).collect();
            check(&gpu, keys, n as u32 + 1000, 8);
            let keys: Vec<u32> = (0..n).map(|_| rng.next_u64() as u32).collect();
            check(&gpu, keys, n as u32, 32);
        }
        // Depth-like keys (bits of positive floats) at a realistic size, with idle capacity.
        let keys: Vec<u32> = (0..300_000)
            .map(|_| rng.range(0.2, 50.0).to_bits())
            .collect();
        check(&gpu, keys, 1 << 20, 32);
    }

    #[test]
    fn sorts_four_million_keys() {
        // Large enough for >1000 blocks per pass and a multi-block histogram scan.
        let gpu = GpuContext::headless().expect("adapter");
        let mut rng = Rng::new(9);
        let keys: Vec<u32> = (0..4_000_000)
            .map(|_| (rng.next_u64() % 65_536) as u32)
            .collect();
        check(&gpu, keys, 4_000_000, 16);
    }

    #[test]
    fn pass_count_covers_the_key_bits() {
        assert_eq!(pass_count(32), 7);
        assert_eq!(pass_count(10), 2);
        assert_eq!(pass_count(11), 3);
        assert_eq!(pass_count(1), 1);
        assert_eq!(pass_count(0), 1);
    }
}
