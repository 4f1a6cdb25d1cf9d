//! Host side of shaders/mesh.wgsl: draws a posed body as a shaded mesh, optionally with its
//! wireframe, into an offscreen image (colour + depth), and blits that image into the viewer's
//! pass. Headless callers read the image back instead ([`MeshPass::read_color`]).
//!
//! Topology is uploaded once per body; vertices (positions + normals) whenever the pose changes.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

use super::shader;
use crate::camera::Camera;

/// The offscreen colour format: display-referred 8-bit, like the splat present's output.
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Depth range of the mesh view; the splat pass's 0.2 near cull is for Gaussians, not here.
const NEAR: f32 = 0.01;
const FAR: f32 = 1000.0;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct MeshUniforms {
    pub clip_from_world: [[f32; 4]; 4],
    pub view_from_world: [[f32; 4]; 4],
    pub surface: [f32; 4],
    pub wire: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct BlitParams {
    pub size: [u32; 2],
    pub srgb_target: u32,
    pub _pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct MeshVertex {
    position: [f32; 3],
    normal: [f32; 3],
}

/// What the mesh view draws.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshStyle {
    pub shaded: bool,
    pub wireframe: bool,
    pub background: [f32; 3],
    /// Drawn over what the viewer drew below (the avatar) at this opacity, instead of on the
    /// background: the mesh's own depth test still hides its far side.
    pub overlay: Option<f32>,
}

/// OpenGL-style clip matrix for [`Camera`]'s pixel-edge intrinsics and x-right, y-down, z-forward
/// view axes; depth maps [NEAR, FAR] to [0, 1].
pub fn clip_from_view(camera: &Camera) -> Mat4 {
    let (w, h) = (camera.width as f32, camera.height as f32);
    let depth = FAR / (FAR - NEAR);
    Mat4::from_cols(
        glam::Vec4::new(2.0 * camera.fx / w, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, -2.0 * camera.fy / h, 0.0, 0.0),
        glam::Vec4::new(
            2.0 * camera.cx / w - 1.0,
            1.0 - 2.0 * camera.cy / h,
            depth,
            1.0,
        ),
        glam::Vec4::new(0.0, 0.0, -NEAR * depth, 0.0),
    )
}

struct Targets {
    size: [u32; 2],
    color: wgpu::Texture,
    depth_view: wgpu::TextureView,
    blit: Option<wgpu::BindGroup>,
}

struct Geometry {
    vertices: wgpu::Buffer,
    vertex_count: usize,
    triangles: wgpu::Buffer,
    triangle_indices: u32,
    edges: wgpu::Buffer,
    edge_indices: u32,
}

pub struct MeshPass {
    shaded: wgpu::RenderPipeline,
    wire: wgpu::RenderPipeline,
    uniforms: wgpu::Buffer,
    bind: wgpu::BindGroup,
    blit: Option<(
        wgpu::RenderPipeline,
        wgpu::BindGroupLayout,
        wgpu::Buffer,
        bool,
    )>,
    geometry: Option<Geometry>,
    targets: Option<Targets>,
}

fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRIBUTES: [wgpu::VertexAttribute; 2] =
        wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];
    wgpu::VertexBufferLayout {
        array_stride: size_of::<MeshVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRIBUTES,
    }
}

impl MeshPass {
    /// `target`: the viewer's colour format to blit into, or `None` for headless use.
    pub fn new(device: &wgpu::Device, target: Option<wgpu::TextureFormat>) -> Self {
        let module = shader::module(device, "mesh.wgsl", shader::MESH, &[]);
        let uniform_entry = |visibility| wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Mesh"),
            entries: &[uniform_entry(wgpu::ShaderStages::VERTEX_FRAGMENT)],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("Mesh"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |label, fragment, topology, bias: wgpu::DepthBiasState, compare| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_mesh"),
                    compilation_options: Default::default(),
                    buffers: &[Some(vertex_layout())],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fragment),
                    compilation_options: Default::default(),
                    targets: &[Some(COLOR_FORMAT.into())],
                }),
                primitive: wgpu::PrimitiveState {
                    topology,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(compare),
                    stencil: Default::default(),
                    bias,
                }),
                multisample: wgpu::MultisampleState::default(),
                multiview_mask: None,
                cache: None,
            })
        };
        // Triangles are pushed back a little so the wireframe drawn over them wins the depth test.
        let pushed_back = wgpu::DepthBiasState {
            constant: 2,
            slope_scale: 1.5,
            clamp: 0.0,
        };
        let shaded = pipeline(
            "Mesh::shaded",
            "fs_shaded",
            wgpu::PrimitiveTopology::TriangleList,
            pushed_back,
            wgpu::CompareFunction::Less,
        );
        let wire = pipeline(
            "Mesh::wire",
            "fs_wire",
            wgpu::PrimitiveTopology::LineList,
            wgpu::DepthBiasState::default(),
            wgpu::CompareFunction::LessEqual,
        );
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Mesh::uniforms"),
            size: size_of::<MeshUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("Mesh"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            }],
        });
        let blit = target.map(|format| {
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("Mesh::blit"),
                entries: &[
                    uniform_entry(wgpu::ShaderStages::FRAGMENT),
                    wgpu::BindGroupLayoutEntry {
                        binding: 1,
                        visibility: wgpu::ShaderStages::FRAGMENT,
                        ty: wgpu::BindingType::Texture {
                            sample_type: wgpu::TextureSampleType::Float { filterable: false },
                            view_dimension: wgpu::TextureViewDimension::D2,
                            multisampled: false,
                        },
                        count: None,
                    },
                ],
            });
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("Mesh::blit"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
            let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("Mesh::blit"),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_blit"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_blit"),
                    compilation_options: Default::default(),
                    // Opaque for the mesh view (alpha 1), blended for an overlay.
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                multiview_mask: None,
                cache: None,
            });
            let params = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("Mesh::blit_params"),
                size: size_of::<BlitParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            (pipeline, layout, params, format.is_srgb())
        });
        Self {
            shaded,
            wire,
            uniforms,
            bind,
            blit,
            geometry: None,
            targets: None,
        }
    }

    /// Uploads a body's triangles and their unique edges (for the wireframe).
    pub fn set_topology(
        &mut self,
        device: &wgpu::Device,
        vertex_count: usize,
        triangles: &[[u32; 3]],
    ) {
        use wgpu::util::DeviceExt;
        let mut edges: Vec<[u32; 2]> = triangles
            .iter()
            .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
            .map(|[a, b]| [a.min(b), a.max(b)])
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let index_buffer = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::INDEX,
            })
        };
        self.geometry = Some(Geometry {
            vertices: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("Mesh::vertices"),
                size: (vertex_count.max(1) * size_of::<MeshVertex>()) as u64,
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            vertex_count,
            triangles: index_buffer("Mesh::triangles", bytemuck::cast_slice(triangles)),
            triangle_indices: (triangles.len() * 3) as u32,
            edges: index_buffer("Mesh::edges", bytemuck::cast_slice(&edges)),
            edge_indices: (edges.len() * 2) as u32,
        });
    }

    /// Uploads posed positions and normals (same count as given to [`MeshPass::set_topology`]).
    pub fn set_vertices(&self, queue: &wgpu::Queue, positions: &[Vec3], normals: &[Vec3]) {
        let Some(g) = &self.geometry else { return };
        let data: Vec<MeshVertex> = positions
            .iter()
            .zip(normals)
            .take(g.vertex_count)
            .map(|(p, n)| MeshVertex {
                position: p.to_array(),
                normal: n.to_array(),
            })
            .collect();
        queue.write_buffer(&g.vertices, 0, bytemuck::cast_slice(&data));
    }

    fn ensure_targets(&mut self, device: &wgpu::Device, size: [u32; 2]) {
        if self.targets.as_ref().is_some_and(|t| t.size == size) {
            return;
        }
        let texture = |label, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: size[0],
                    height: size[1],
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        use wgpu::TextureUsages as U;
        let color = texture(
            "Mesh::color",
            COLOR_FORMAT,
            U::RENDER_ATTACHMENT | U::TEXTURE_BINDING | U::COPY_SRC,
        );
        let depth = texture("Mesh::depth", DEPTH_FORMAT, U::RENDER_ATTACHMENT);
        let blit = self.blit.as_ref().map(|(_, layout, params, _)| {
            let view = color.create_view(&Default::default());
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("Mesh::blit"),
                layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&view),
                    },
                ],
            })
        });
        self.targets = Some(Targets {
            size,
            depth_view: depth.create_view(&Default::default()),
            color,
            blit,
        });
    }

    /// Records the mesh view for `camera` into the offscreen image (resized to the camera's).
    pub fn encode(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        camera: &Camera,
        style: &MeshStyle,
    ) {
        let size = [camera.width.max(1), camera.height.max(1)];
        self.ensure_targets(device, size);
        let opacity = style.overlay.unwrap_or(1.0).clamp(0.0, 1.0);
        let uniforms = MeshUniforms {
            clip_from_world: (clip_from_view(camera) * camera.view_from_world).to_cols_array_2d(),
            view_from_world: camera.view_from_world.to_cols_array_2d(),
            surface: [0.78, 0.72, 0.66, opacity],
            wire: if style.shaded {
                [0.12, 0.16, 0.22, opacity]
            } else {
                [0.85, 0.88, 0.92, opacity]
            },
        };
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        if let Some((_, _, params, srgb)) = &self.blit {
            let p = BlitParams {
                size,
                srgb_target: *srgb as u32,
                _pad: 0,
            };
            queue.write_buffer(params, 0, bytemuck::bytes_of(&p));
        }
        let Some(targets) = &self.targets else { return };
        let color_view = targets.color.create_view(&Default::default());
        let [r, g, b] = style.background.map(f64::from);
        // An overlay's empty pixels are transparent: the blit leaves the image below there.
        let a = if style.overlay.is_some() { 0.0 } else { 1.0 };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("Mesh"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let Some(g) = &self.geometry else { return };
        pass.set_bind_group(0, &self.bind, &[]);
        pass.set_vertex_buffer(0, g.vertices.slice(..));
        if style.shaded {
            pass.set_pipeline(&self.shaded);
            pass.set_index_buffer(g.triangles.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..g.triangle_indices, 0, 0..1);
        }
        if style.wireframe || !style.shaded {
            pass.set_pipeline(&self.wire);
            pass.set_index_buffer(g.edges.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..g.edge_indices, 0, 0..1);
        }
    }

    /// The last image drawn, as RGBA8 rows (waits for the GPU; for tests and exports).
    pub fn read_color(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Option<Vec<u8>> {
        let color = &self.targets.as_ref()?.color;
        Some(super::readback::read_texture_bytes(device, queue, color))
    }

    /// Draws the last encoded image into the viewer's pass (needs a `target` at construction).
    pub fn draw_blit(&self, pass: &mut wgpu::RenderPass<'_>) {
        let (
            Some((pipeline, ..)),
            Some(Targets {
                blit: Some(bind), ..
            }),
        ) = (&self.blit, &self.targets)
        else {
            return;
        };
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.draw(0..3, 0..1);
    }
}
