//! The one place the splatting pass waits for the GPU: copy buffers to staging, map, wait.
//! The frame loop never calls this; headless rendering, tests and benchmarks do.

pub fn read_buffers(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    sources: &[(&wgpu::Buffer, u64)],
) -> Vec<Vec<u8>> {
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("readback"),
    });
    let staging: Vec<_> = sources
        .iter()
        .map(|(src, size)| {
            let dst = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback::staging"),
                size: *size,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            });
            encoder.copy_buffer_to_buffer(src, 0, &dst, 0, *size);
            dst
        })
        .collect();
    queue.submit([encoder.finish()]);
    for buf in &staging {
        buf.slice(..).map_async(wgpu::MapMode::Read, |r| {
            if let Err(e) = r {
                log::error!("readback map failed: {e}");
            }
        });
    }
    wait(device);
    staging
        .iter()
        .map(|buf| {
            let bytes = buf
                .slice(..)
                .get_mapped_range()
                .map(|view| view.to_vec())
                .unwrap_or_default();
            buf.unmap();
            bytes
        })
        .collect()
}

/// Blocks until the queue is idle.
pub fn wait(device: &wgpu::Device) {
    if let Err(e) = device.poll(wgpu::PollType::wait_indefinitely()) {
        log::error!("waiting for the GPU failed: {e}");
    }
}

/// All layers of a float 2D array texture (r32float, rgba32float…) as one f32 vector, layer-major
/// with the texel's channels innermost ([L, H, W, channels]).
pub fn read_texture_floats(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> Vec<f32> {
    bytemuck::pod_collect_to_vec(&read_texture_bytes(device, queue, texture))
}

/// The texels of a texture (r32float, rgba8, rgba32float…), layer-major and row-major.
/// Rows are padded to wgpu's 256-byte copy alignment on the GPU and unpadded here.
pub fn read_texture_bytes(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> Vec<u8> {
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("readback::texture"),
    });
    let copy = TextureCopy::encode(device, &mut encoder, texture);
    queue.submit([encoder.finish()]);
    copy.map();
    wait(device);
    copy.bytes()
}

/// A texture's texels copied into a staging buffer by a command encoder, to be read once that
/// work is submitted: blocking ([`read_texture_bytes`]) or from a worker thread while the frame
/// loop goes on (the viewer's refiner on the CPU).
pub struct TextureCopy {
    staging: wgpu::Buffer,
    /// Bytes of one row of texels, and of one row in the staging buffer.
    row: usize,
    padded: usize,
}

impl TextureCopy {
    /// Records the copy of every layer of `texture`.
    pub fn encode(
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        texture: &wgpu::Texture,
    ) -> Self {
        let size = texture.size();
        let (w, h, layers) = (
            size.width as usize,
            size.height as usize,
            size.depth_or_array_layers as usize,
        );
        let texel = texture
            .format()
            .block_copy_size(None)
            .expect("a colour format") as usize;
        let row = w * texel;
        let padded = row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize);
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback::texture"),
            size: (padded * h * layers) as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded as u32),
                    rows_per_image: Some(h as u32),
                },
            },
            size,
        );
        Self {
            staging,
            row,
            padded,
        }
    }

    /// Asks for the staging buffer once the copy's submission is done (submit it first); the
    /// bytes are there after the device is polled past it ([`wait`]).
    pub fn map(&self) {
        self.staging.slice(..).map_async(wgpu::MapMode::Read, |r| {
            if let Err(e) = r {
                log::error!("texture readback map failed: {e}");
            }
        });
    }

    /// The texels, unpadded (empty if the buffer could not be mapped).
    pub fn bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        if let Ok(view) = self.staging.slice(..).get_mapped_range() {
            out.reserve(view.len() / self.padded * self.row);
            for chunk in view.chunks_exact(self.padded) {
                out.extend_from_slice(&chunk[..self.row]);
            }
        }
        self.staging.unmap();
        out
    }
}
