//! Host side of shaders/scan.wgsl: an in-place exclusive prefix sum over the first `count` u32 of a
//! buffer, whose grand total is written to `totals[total_index]`. Dispatches are sized for the
//! buffer's capacity; [`PrefixScan::set_count`] sets the live count (the scan is in place, so
//! entries past it hold last frame's sums and must never be read).

use super::layout::ScanParams;
use super::pipelines::{SplatPipelines, dispatch_1d};
use wgpu::util::DeviceExt;

pub const SCAN_BLOCK: u32 = 2048;

pub(crate) struct PrefixScan {
    bind_group: wgpu::BindGroup,
    params: wgpu::Buffer,
    total_index: u32,
    /// Blocks dispatched: enough for the capacity; blocks past the live count exit at once.
    num_blocks: u32,
}

impl PrefixScan {
    pub fn new(
        device: &wgpu::Device,
        pipes: &SplatPipelines,
        label: &str,
        data: &wgpu::Buffer,
        count: u32,
        totals: &wgpu::Buffer,
        total_index: u32,
    ) -> Self {
        let num_blocks = count.div_ceil(SCAN_BLOCK).max(1);
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(&format!("{label}::params")),
            contents: bytemuck::bytes_of(&Self::params(count, total_index)),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let block_sums = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(&format!("{label}::block_sums")),
            size: num_blocks as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &pipes.scan_layout,
            entries: &[
                entry(0, &params),
                entry(1, data),
                entry(2, &block_sums),
                entry(3, totals),
            ],
        });
        Self {
            bind_group,
            params,
            total_index,
            num_blocks,
        }
    }

    fn params(count: u32, total_index: u32) -> ScanParams {
        ScanParams {
            count,
            num_blocks: count.div_ceil(SCAN_BLOCK).max(1),
            total_index,
            _pad: 0,
        }
    }

    /// Scans only the first `count` entries from now on (at most the capacity given to `new`).
    pub fn set_count(&self, queue: &wgpu::Queue, count: u32) {
        let params = Self::params(count, self.total_index);
        assert!(
            params.num_blocks <= self.num_blocks,
            "scan count {count} exceeds its capacity"
        );
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
    }

    pub fn encode(&self, pipes: &SplatPipelines, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_pipeline(&pipes.scan_reduce);
        dispatch_1d(pass, self.num_blocks);
        pass.set_pipeline(&pipes.scan_sums);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(&pipes.scan_blocks);
        dispatch_1d(pass, self.num_blocks);
    }
}

pub(crate) fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}
