//! Host side of shaders/present.wgsl: draws a [`Splatter`]'s output (rendered on black) over a
//! background into a render pass, reading its textures directly; or a refined picture the same
//! way. Used by the viewer's paint callback.

use super::Splatter;
use super::shader;
use super::splatter::array_view;
use bytemuck::{Pod, Zeroable};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PresentMode {
    /// Three feature channels as RGB.
    #[default]
    Rgb,
    Alpha,
    InverseDepth,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct PresentUniform {
    pub size: [u32; 2],
    pub mode: u32,
    pub srgb_target: u32,
    pub rgb_channels: [u32; 4],
    pub inv_depth_range: [f32; 2],
    pub _pad: [f32; 2],
    /// What the picture is composited over (the displayed channels' background), by its alpha.
    pub background: [f32; 4],
}
const _: () = assert!(size_of::<PresentUniform>() == 64);

/// The shader's mode for a refined picture (premultiplied RGB and alpha in one texel).
const MODE_REFINED: u32 = 3;

pub struct PresentPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    srgb_target: bool,
}

impl PresentPass {
    pub fn new(device: &wgpu::Device, target: wgpu::TextureFormat) -> Self {
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty,
            count: None,
        };
        let layers = wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Present"),
            entries: &[
                entry(
                    0,
                    wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                ),
                entry(1, layers),
                entry(2, layers),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("Present"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = shader::module(device, "present.wgsl", shader::PRESENT, &[]);
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("Present"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(target.into())],
            }),
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            multiview_mask: None,
            cache: None,
        });
        Self {
            pipeline,
            layout,
            srgb_target: target.is_srgb(),
        }
    }

    pub fn uniform(
        &self,
        size: [u32; 2],
        mode: PresentMode,
        rgb_channels: [u32; 3],
        inv_depth_range: [f32; 2],
        background: [f32; 3],
    ) -> PresentUniform {
        let [r, g, b] = background;
        PresentUniform {
            size,
            mode: mode as u32,
            srgb_target: self.srgb_target as u32,
            rgb_channels: [rgb_channels[0], rgb_channels[1], rgb_channels[2], 0],
            inv_depth_range,
            _pad: [0.0; 2],
            background: [r, g, b, 0.0],
        }
    }

    /// For a refined picture of `size` ([`Self::bind_refined`]) over `background`.
    pub fn refined_uniform(&self, size: [u32; 2], background: [f32; 3]) -> PresentUniform {
        PresentUniform {
            mode: MODE_REFINED,
            ..self.uniform(size, PresentMode::Rgb, [0, 1, 2], [0.0, 1.0], background)
        }
    }

    /// Binds a refined picture: `refined` (rgba32float, one layer) with the splat's alpha and
    /// depth beside it.
    pub fn bind_refined(
        &self,
        device: &wgpu::Device,
        uniform: &wgpu::Buffer,
        refined: &wgpu::Texture,
        splatter: &Splatter,
    ) -> Option<wgpu::BindGroup> {
        Some(self.bind_views(
            device,
            uniform,
            &array_view(refined),
            &array_view(splatter.aux()?),
        ))
    }

    /// Binds the splatter's current output; rebuild when the splatter reallocates.
    pub fn bind(
        &self,
        device: &wgpu::Device,
        uniform: &wgpu::Buffer,
        splatter: &Splatter,
    ) -> Option<wgpu::BindGroup> {
        let (features, aux) = (
            array_view(splatter.features()?),
            array_view(splatter.aux()?),
        );
        Some(self.bind_views(device, uniform, &features, &aux))
    }

    fn bind_views(
        &self,
        device: &wgpu::Device,
        uniform: &wgpu::Buffer,
        features: &wgpu::TextureView,
        aux: &wgpu::TextureView,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("Present"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(features),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(aux),
                },
            ],
        })
    }

    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, bind_group: &wgpu::BindGroup) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
}
