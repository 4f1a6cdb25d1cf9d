//! A GPU-resident avatar and the rig pass that poses it (shaders/rig.wgsl). What does not change
//! with the pose — each Gaussian's local rotation, scale, opacity and features, the UV
//! Gaussians' triangles, barycentrics and offsets, the mesh's triangles — goes up once; a frame
//! sends only the posed vertices and their skinning rotations (64 bytes a vertex: ~1 MB for the
//! default body against ~9 MB for its 141k posed Gaussians), and the rig pass writes every
//! Gaussian's position, rotation and scale straight into the splatting pass's input.

use std::sync::Arc;

use super::layout::{
    PosedVertex, RigParams, SkinnedGaussian, TRIANGLE_FRAME_SIZE, TemplateGaussian, UvGaussian,
};
use super::pipelines::{SplatPipelines, dispatch_1d};
use super::scan::entry;
use super::{SplatError, Splatter};
use crate::avatar::{Avatar, BodyMismatch, Dressing, HandsInView};
use crate::body::PosedBody;

/// An avatar's constant data on the GPU, and its posed vertices.
pub struct GpuAvatar {
    pipes: Arc<SplatPipelines>,
    template_count: u32,
    skinned_count: u32,
    /// UV Gaussians in all, the last `outside` of them on parts the photo did not show.
    uv_total: u32,
    outside: u32,
    /// Whether those are drawn.
    show_outside: bool,
    triangle_count: u32,
    channels: u32,
    low_pass: crate::gaussians::LowPass,
    body: (String, usize, usize),
    /// Template, skinned then UV features, Gaussian-major: written into the splatter once per
    /// reallocation of its buffers (they live there, where the rasterizer reads them).
    features: Vec<f32>,
    /// The clothing the avatar wears, applied to each pose on the CPU before it goes up, with the
    /// mesh and weld its normals need.
    displacements: Vec<f32>,
    mesh: Vec<[u32; 3]>,
    weld: Option<Vec<u32>>,
    dressing: Dressing,
    params: wgpu::Buffer,
    template: wgpu::Buffer,
    skinned: wgpu::Buffer,
    uv: wgpu::Buffer,
    triangles: wgpu::Buffer,
    posed: wgpu::Buffer,
    /// Each posed triangle's corners and frame, between the rig's frames and UV passes.
    frames: wgpu::Buffer,
    /// The splatter buffers generation and the count drawn the bind group and the features
    /// were made for.
    bound: Option<((u64, usize), wgpu::BindGroup)>,
    scratch: Vec<PosedVertex>,
    /// The hands the photo did not show, drawn only where it looked: each posed vertex carries
    /// its visibility (1 or 0) in its position's w, by which the rig scales opacities.
    hands: Option<Arc<HandsInView>>,
    visibility: Vec<f32>,
}

fn constant(
    device: &wgpu::Device,
    label: &str,
    bytes: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    // wgpu refuses empty bindings: an avatar without UV Gaussians still binds 16 bytes.
    let padded;
    let contents = if bytes.len() < 16 {
        padded = [bytes, &[0u8; 16][bytes.len()..]].concat();
        &padded[..]
    } else {
        bytes
    };
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage,
    })
}

impl GpuAvatar {
    /// Uploads `avatar`, bound to a body whose mesh is `triangles`, welded at its UV seams by
    /// `weld` ([`crate::body::Posable::weld`]).
    pub fn new(
        device: &wgpu::Device,
        pipes: Arc<SplatPipelines>,
        avatar: &Avatar,
        triangles: &[[u32; 3]],
        weld: Option<&[u32]>,
    ) -> Self {
        let t = &avatar.template;
        let template: Vec<TemplateGaussian> = (0..t.len())
            .map(|i| TemplateGaussian {
                rot: t.rotations[i],
                scale: t.scales[i],
                opacity: t.opacities[i],
            })
            .collect();
        let u = &avatar.uv;
        let uv: Vec<UvGaussian> = (0..u.local.len())
            .map(|i| UvGaussian {
                bary: u.barycentrics[i],
                triangle: u.triangles[i],
                offset: u.offsets[i],
                opacity: u.local.opacities[i],
                rot: u.local.rotations[i],
                scale: u.local.scales[i],
                _pad: 0.0,
            })
            .collect();
        let k = &avatar.skinned;
        let skinned: Vec<SkinnedGaussian> = (0..k.len())
            .map(|i| SkinnedGaussian {
                vertices: k.vertices[i],
                weights: k.weights[i],
                offset: k.offsets[i],
                opacity: k.local.opacities[i],
                rot: k.local.rotations[i],
                scale: k.local.scales[i],
                _pad: 0.0,
            })
            .collect();
        let params = RigParams {
            template_count: template.len() as u32,
            uv_count: (uv.len() - avatar.outside) as u32,
            triangle_count: triangles.len() as u32,
            skinned_count: skinned.len() as u32,
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let flat: Vec<u32> = triangles.iter().flatten().copied().collect();
        let mut features = t.features.clone();
        features.extend_from_slice(&k.local.features);
        features.extend_from_slice(&u.local.features);
        Self {
            template_count: params.template_count,
            skinned_count: params.skinned_count,
            uv_total: uv.len() as u32,
            outside: avatar.outside as u32,
            show_outside: false,
            triangle_count: params.triangle_count,
            channels: avatar.channels as u32,
            low_pass: avatar.kind.low_pass(),
            body: (
                avatar.body.clone(),
                avatar.body_vertices,
                avatar.body_triangles,
            ),
            features,
            displacements: avatar.displacements.clone(),
            mesh: if avatar.displacements.is_empty() {
                Vec::new()
            } else {
                triangles.to_vec()
            },
            weld: weld
                .filter(|_| !avatar.displacements.is_empty())
                .map(<[u32]>::to_vec),
            dressing: Dressing::default(),
            params: constant(
                device,
                "Rig::params",
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            template: constant(
                device,
                "Rig::template",
                bytemuck::cast_slice(&template),
                storage,
            ),
            skinned: constant(
                device,
                "Rig::skinned",
                bytemuck::cast_slice(&skinned),
                storage,
            ),
            uv: constant(device, "Rig::uv", bytemuck::cast_slice(&uv), storage),
            triangles: constant(
                device,
                "Rig::triangles",
                bytemuck::cast_slice(&flat),
                storage,
            ),
            posed: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("Rig::posed"),
                size: (avatar.body_vertices.max(1) * size_of::<PosedVertex>()) as u64,
                usage: storage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            frames: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("Rig::frames"),
                size: triangles.len().max(1) as u64 * TRIANGLE_FRAME_SIZE,
                usage: storage,
                mapped_at_creation: false,
            }),
            pipes,
            bound: None,
            scratch: Vec::new(),
            hands: None,
            visibility: Vec::new(),
        }
    }

    /// The UV Gaussians drawn.
    fn uv_count(&self) -> u32 {
        if self.show_outside {
            self.uv_total
        } else {
            self.uv_total - self.outside
        }
    }

    /// Gaussians drawn: template, skinned, then UV.
    pub fn len(&self) -> usize {
        (self.template_count + self.skinned_count + self.uv_count()) as usize
    }

    /// Draws the parts the photo did not show (in neutral grey) too, or not; takes effect at the
    /// next [`Self::attach`] and [`Self::encode`], and for the hands it did not show (drawn
    /// wherever they are while it is on) at the next [`Self::set_pose`].
    pub fn show_outside(&mut self, queue: &wgpu::Queue, show: bool) {
        if show == self.show_outside {
            return;
        }
        self.show_outside = show;
        let params = RigParams {
            template_count: self.template_count,
            uv_count: self.uv_count(),
            triangle_count: self.triangle_count,
            skinned_count: self.skinned_count,
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// GPU memory its own buffers hold (its Gaussians' features live in the splatter it is
    /// attached to).
    pub fn gpu_bytes(&self) -> u64 {
        [
            &self.params,
            &self.template,
            &self.skinned,
            &self.uv,
            &self.triangles,
            &self.posed,
            &self.frames,
        ]
        .iter()
        .map(|b| b.size())
        .sum()
    }

    /// Makes `splatter` hold this avatar: room for the Gaussians drawn and their features,
    /// written again only when the splatter's buffers were reallocated, held something else, or
    /// the Gaussians drawn changed.
    pub fn attach(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        splatter: &mut Splatter,
    ) -> Result<(), SplatError> {
        let count = self.len();
        splatter.reserve(device, queue, count, self.channels)?;
        splatter.set_low_pass(self.low_pass);
        let generation = (splatter.buffers_generation(), count);
        if self.bound.as_ref().is_some_and(|(g, _)| *g == generation) {
            return Ok(());
        }
        splatter.write_features(queue, &self.features[..count * self.channels as usize]);
        let Some(output) = splatter.gaussian_buffer() else {
            return Ok(());
        };
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("Rig"),
            layout: &self.pipes.rig_layout,
            entries: &[
                entry(0, &self.params),
                entry(1, &self.template),
                entry(2, &self.uv),
                entry(3, &self.triangles),
                entry(4, &self.posed),
                entry(5, &self.frames),
                entry(6, output),
                entry(7, &self.skinned),
            ],
        });
        self.bound = Some((generation, bind));
        Ok(())
    }

    /// Forgets which splatter this avatar was written into (another content took its place).
    pub fn detach(&mut self) {
        self.bound = None;
    }

    /// Draws the hands the photo did not show only where it looked (`None`: as the avatar has
    /// them), from the next [`Self::set_pose`] on.
    pub fn set_hands(&mut self, hands: Option<Arc<HandsInView>>) {
        self.hands = hands;
    }

    /// Uploads the posed body (its vertices, dressed in the avatar's clothing, and its skinning
    /// rotations) for the next [`Self::encode`].
    pub fn set_pose(&mut self, queue: &wgpu::Queue, posed: &PosedBody) -> Result<(), BodyMismatch> {
        let (name, vertices, triangles) = &self.body;
        if posed.vertices.len() != *vertices || posed.skin.len() != *vertices {
            return Err(BodyMismatch {
                body: name.clone(),
                expected_vertices: *vertices,
                expected_triangles: *triangles,
                vertices: posed.vertices.len(),
                triangles: *triangles,
            });
        }
        let vertices = self.dressing.apply(
            &self.displacements,
            &posed.vertices,
            &self.mesh,
            self.weld.as_deref(),
        );
        self.visibility.clear();
        // With the body the photo did not show drawn, so are its hands, wherever they are.
        if let Some(hands) = self.hands.as_ref().filter(|_| !self.show_outside) {
            hands.visibility(posed, &mut self.visibility);
        }
        let seen = |i: usize| self.visibility.get(i).copied().unwrap_or(1.0);
        self.scratch.clear();
        self.scratch.extend(
            vertices
                .iter()
                .zip(&posed.skin)
                .enumerate()
                .map(|(i, (v, skin))| {
                    let m = skin.matrix3;
                    PosedVertex {
                        position: v.extend(seen(i)).to_array(),
                        skin: [m.x_axis, m.y_axis, m.z_axis].map(|c| c.extend(0.0).to_array()),
                    }
                }),
        );
        queue.write_buffer(&self.posed, 0, bytemuck::cast_slice(&self.scratch));
        Ok(())
    }

    /// Records the rig pass: every Gaussian posed into the splatter it is attached to.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder) {
        let Some((_, bind)) = &self.bound else {
            log::warn!("rig pass encoded before the avatar was attached; skipped");
            return;
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("rig"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, bind, &[]);
        // Frames first: the UV pass reads them.
        for (pipeline, count) in [
            (&self.pipes.rig_frames, self.triangle_count),
            (&self.pipes.rig_template, self.template_count),
            (&self.pipes.rig_skinned, self.skinned_count),
            (&self.pipes.rig_uv, self.uv_count()),
        ] {
            pass.set_pipeline(pipeline);
            dispatch_1d(&mut pass, count.div_ceil(256));
        }
    }
}
