//! GPU timestamps around each stage of the splatting pass, where the adapter has them.

use super::readback::read_buffers;
use super::splatter::Stage;

pub struct StageTimer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    period_ns: f32,
}

impl StageTimer {
    /// `None` when the device was created without `TIMESTAMP_QUERY`.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Option<Self> {
        if !device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let count = 2 * Stage::ALL.len() as u32;
        Some(Self {
            queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("Splat::timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("Splat::timestamps_resolve"),
                size: count as u64 * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            period_ns: queue.get_timestamp_period(),
        })
    }

    fn index(stage: Stage) -> u32 {
        Stage::ALL.iter().position(|s| *s == stage).unwrap_or(0) as u32
    }

    pub fn writes(&self, stage: Stage) -> wgpu::ComputePassTimestampWrites<'_> {
        let i = Self::index(stage);
        wgpu::ComputePassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(2 * i),
            end_of_pass_write_index: Some(2 * i + 1),
        }
    }

    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(
            &self.queries,
            0..2 * Stage::ALL.len() as u32,
            &self.resolve,
            0,
        );
    }

    /// Milliseconds per stage, in [`Stage::ALL`] order (waits for the GPU).
    pub fn read_ms(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Vec<f64> {
        let bytes = read_buffers(device, queue, &[(&self.resolve, self.resolve.size())]);
        self.ms(bytemuck::cast_slice(&bytes[0]))
    }

    /// Bytes of resolved timestamps ([`Self::copy_resolved`] copies them).
    pub fn resolved_size(&self) -> u64 {
        self.resolve.size()
    }

    /// Copies the resolved timestamps into `dst` at `offset`, to read without waiting.
    pub fn copy_resolved(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        dst: &wgpu::Buffer,
        offset: u64,
    ) {
        encoder.copy_buffer_to_buffer(&self.resolve, 0, dst, offset, self.resolve.size());
    }

    /// Milliseconds per stage from resolved timestamps (begin, end per stage).
    pub fn ms(&self, ticks: &[u64]) -> Vec<f64> {
        ticks
            .chunks_exact(2)
            .map(|t| t[1].saturating_sub(t[0]) as f64 * self.period_ns as f64 * 1e-6)
            .collect()
    }
}
