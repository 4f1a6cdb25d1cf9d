//! A refiner network run by our own compute passes (shaders/refine.wgsl) on the splatting
//! device, its weights read from the ONNX file's initializers (`onnx_model`): the splat layers
//! are gathered into its input where they lie, and only its output is read back.
//!
//! Runs graphs of Conv (any kernel, stride and padding; no groups or dilation; a following ReLU
//! fused), Relu, Sigmoid, Clip, Add (equal shapes), Resize (linear, half_pixel), Concat and Slice
//! (both over channels), batch 1. Anything else is refused naming the operator, so the caller
//! can run that model through ONNX Runtime instead.

use std::collections::HashMap;

use wgpu::util::DeviceExt;

use crate::gpu::GpuContext;
use crate::onnx_model::{Attribute, Model, Node, Tensor, TensorData};
use crate::render::pipelines::{Binding, bind_group_layout, compute_pipeline, dispatch_1d};
use crate::render::readback::read_buffers;
use crate::render::shader;

/// The shaders' `Op` (shaders/refine.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct OpParams {
    pub in_c: u32,
    pub in_h: u32,
    pub in_w: u32,
    pub out_c: u32,
    pub out_h: u32,
    pub out_w: u32,
    pub kernel_h: u32,
    pub kernel_w: u32,
    pub stride_h: u32,
    pub stride_w: u32,
    pub pad_top: u32,
    pub pad_left: u32,
    pub kind: u32,
    pub src_channel: u32,
    pub dst_channel: u32,
    pub lo: f32,
    pub hi: f32,
    pub scale_h: f32,
    pub scale_w: f32,
    /// The shader's `_pad: vec4<u32>` at offset 80 (16-aligned), and the word before it.
    pub _pad: [u32; 5],
}

/// Output pixels a convolution thread makes (`CONV_PIXELS` in shaders/refine.wgsl).
const CONV_PIXELS: u32 = 4;

// `Op.kind` (shaders/refine.wgsl).
const UNARY_NONE: u32 = 0;
const UNARY_RELU: u32 = 1;
const UNARY_SIGMOID: u32 = 2;
const UNARY_CLIP: u32 = 3;

/// Where one input channel comes from in the splatting pass's output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layer {
    /// A splat channel, by index (the gather finds its texel and lane).
    Feature(u32),
    Alpha,
}

/// A value of the graph, by index.
type Value = usize;

/// One operator, shape-free (shapes follow from the input's size, [`Plan`]).
enum Step {
    Conv {
        src: Value,
        dst: Value,
        /// Biases then weights, packed as the shader reads them.
        weights: wgpu::Buffer,
        in_c: u32,
        out_c: u32,
        kernel: [u32; 2],
        stride: [u32; 2],
        /// Top, left, bottom, right.
        pads: [u32; 4],
        kind: u32,
    },
    Unary {
        src: Value,
        dst: Value,
        kind: u32,
        bounds: [f32; 2],
    },
    Add {
        a: Value,
        b: Value,
        dst: Value,
    },
    Resize {
        src: Value,
        dst: Value,
        scale: [f32; 2],
    },
    Concat {
        srcs: Vec<Value>,
        dst: Value,
    },
    Slice {
        src: Value,
        dst: Value,
        start: i64,
        end: i64,
    },
}

/// The compute pipelines, one per entry point.
struct Pipelines {
    conv: (wgpu::ComputePipeline, wgpu::BindGroupLayout),
    resize: (wgpu::ComputePipeline, wgpu::BindGroupLayout),
    copy: (wgpu::ComputePipeline, wgpu::BindGroupLayout),
    unary: (wgpu::ComputePipeline, wgpu::BindGroupLayout),
    add: (wgpu::ComputePipeline, wgpu::BindGroupLayout),
    gather: (wgpu::ComputePipeline, wgpu::BindGroupLayout),
    rgba: (wgpu::ComputePipeline, wgpu::BindGroupLayout),
}

impl Pipelines {
    fn new(device: &wgpu::Device) -> Self {
        let module = shader::module(device, "refine", shader::REFINE, &[]);
        let read = Binding::Storage { read_only: true };
        let write = Binding::Storage { read_only: false };
        let make = |entry: &str, bindings: &[Binding]| {
            let label = format!("refine::{entry}");
            let layout = bind_group_layout(device, &label, bindings);
            let pipeline = compute_pipeline(device, &label, &layout, &module, entry);
            (pipeline, layout)
        };
        use Binding::{InputTexture, Uniform};
        Self {
            conv: make("conv", &[Uniform, read, write, read]),
            resize: make("resize", &[Uniform, read, write]),
            copy: make("copy_channels", &[Uniform, read, write]),
            unary: make("unary", &[Uniform, read, write]),
            add: make("add", &[Uniform, read, write, Binding::Skip, read]),
            gather: make(
                "gather",
                &[
                    Uniform,
                    Binding::Skip,
                    write,
                    Binding::Skip,
                    Binding::Skip,
                    InputTexture,
                    InputTexture,
                    read,
                ],
            ),
            rgba: make(
                "to_rgba",
                &[
                    Uniform,
                    read,
                    Binding::Skip,
                    Binding::Skip,
                    Binding::Skip,
                    Binding::Skip,
                    InputTexture,
                    Binding::Skip,
                    Binding::OutputTexture(wgpu::TextureFormat::Rgba32Float),
                ],
            ),
        }
    }
}

/// A network compiled for the device; [`WgslNetwork::run_splat`] and
/// [`WgslNetwork::run_tensor`] run it.
pub struct WgslNetwork {
    gpu: GpuContext,
    pipelines: Pipelines,
    steps: Vec<Step>,
    values: usize,
    input: Value,
    output: Value,
    pub input_channels: u32,
    plan: Option<Plan>,
}

/// Shapes, buffers and bind groups for one input size.
struct Plan {
    size: [u32; 2],
    shapes: Vec<[u32; 3]>,
    buffers: Vec<wgpu::Buffer>,
    dispatches: Vec<Dispatch>,
}

/// One compute dispatch of a plan: workgroups `[n, 0, 0]` are a flat count (`dispatch_1d`).
struct Dispatch {
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    groups: [u32; 3],
}

impl WgslNetwork {
    /// Compiles `model`'s graph for `gpu`'s device and uploads its weights.
    pub fn compile(gpu: &GpuContext, model: &Model) -> Result<Self, String> {
        let [input] = &model.inputs[..] else {
            return Err(format!("has {} inputs; one is run", model.inputs.len()));
        };
        let [output] = &model.outputs[..] else {
            return Err(format!("has {} outputs; one is run", model.outputs.len()));
        };
        let input_channels = match input.dims[..] {
            [Some(1), Some(c), _, _] if c > 0 => c as u32,
            ref dims => {
                return Err(format!(
                    "input `{}` is {dims:?}, not [1, C, H, W]",
                    input.name
                ));
            }
        };
        let mut compiler = Compiler {
            device: &gpu.device,
            model,
            values: HashMap::from([(input.name.clone(), 0)]),
            constants: model
                .initializers
                .iter()
                .map(|(k, v)| (k.clone(), v))
                .collect(),
            consumers: HashMap::new(),
            steps: Vec::new(),
            fused: Vec::new(),
        };
        for node in &model.nodes {
            for name in &node.inputs {
                *compiler.consumers.entry(name.as_str()).or_default() += 1;
            }
        }
        for name in model.outputs.iter().map(|o| o.name.as_str()) {
            *compiler.consumers.entry(name).or_default() += 1;
        }
        for (i, node) in model.nodes.iter().enumerate() {
            compiler
                .node(i, node)
                .map_err(|e| format!("node {i} ({}): {e}", node.op))?;
        }
        let output_value = compiler.value(&output.name)?;
        let (steps, values) = (compiler.steps, compiler.values.len());
        Ok(Self {
            pipelines: Pipelines::new(&gpu.device),
            gpu: gpu.clone(),
            steps,
            values,
            input: 0,
            output: output_value,
            input_channels,
            plan: None,
        })
    }

    /// Runs on `input` ([C, H, W]) and reads the output back: ([C, H, W], its C).
    pub fn run_tensor(&mut self, input: &[f32], h: u32, w: u32) -> Result<(Vec<f32>, u32), String> {
        let expected = self.input_channels as usize * h as usize * w as usize;
        if input.len() != expected {
            return Err(format!(
                "input holds {} values, [{}, {h}, {w}] is {expected}",
                input.len(),
                self.input_channels
            ));
        }
        self.plan_for(h, w)?;
        let plan = self.plan.as_ref().expect("planned");
        self.gpu
            .queue
            .write_buffer(&plan.buffers[self.input], 0, bytemuck::cast_slice(input));
        let mut encoder = self.encoder();
        self.encode(&mut encoder);
        Ok(self.finish(encoder))
    }

    /// Runs on the splatting pass's output, `layers` gathered from its feature and aux
    /// textures (`size`: the image's) into an input of `padded` size (zero beyond the image),
    /// and reads the output back.
    pub fn run_splat(
        &mut self,
        features: &wgpu::Texture,
        aux: &wgpu::Texture,
        layers: &[Layer],
        size: [u32; 2],
        padded: [u32; 2],
    ) -> Result<(Vec<f32>, u32), String> {
        let mut encoder = self.encoder();
        self.encode_splat(&mut encoder, features, aux, layers, size, padded)?;
        Ok(self.finish(encoder))
    }

    /// Records [`Self::run_splat`]'s work into `encoder`, leaving the output on the device
    /// ([`Self::encode_rgba`] writes it into a texture).
    pub fn encode_splat(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        features: &wgpu::Texture,
        aux: &wgpu::Texture,
        layers: &[Layer],
        size: [u32; 2],
        padded: [u32; 2],
    ) -> Result<(), String> {
        if layers.len() != self.input_channels as usize {
            return Err(format!(
                "the network reads {} channels, {} were given",
                self.input_channels,
                layers.len()
            ));
        }
        self.plan_for(padded[1], padded[0])?;
        let device = &self.gpu.device;
        let codes: Vec<u32> = layers
            .iter()
            .map(|l| match l {
                Layer::Feature(i) => *i,
                Layer::Alpha => GATHER_ALPHA,
            })
            .collect();
        let plan = self.plan.as_ref().expect("planned");
        let params = OpParams {
            in_h: size[1],
            in_w: size[0],
            out_c: self.input_channels,
            out_h: padded[1],
            out_w: padded[0],
            ..Default::default()
        };
        let uniform = uniform(device, &params);
        let codes = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("refine::gather layers"),
            contents: bytemuck::cast_slice(&codes),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let view = |t: &wgpu::Texture| crate::render::splatter::array_view(t);
        let (features, aux) = (view(features), view(aux));
        let (pipeline, layout) = &self.pipelines.gather;
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("refine::gather"),
            layout,
            entries: &[
                entry(0, uniform.as_entire_binding()),
                entry(2, plan.buffers[self.input].as_entire_binding()),
                entry(5, wgpu::BindingResource::TextureView(&features)),
                entry(6, wgpu::BindingResource::TextureView(&aux)),
                entry(7, codes.as_entire_binding()),
            ],
        });
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(
                padded[0].div_ceil(8),
                padded[1].div_ceil(8),
                self.input_channels,
            );
        }
        self.encode(encoder);
        Ok(())
    }

    /// Records the copy of a four-channel output (the default refiner's premultiplied RGB and
    /// alpha, [4, padded H, padded W]) into `target`, an rgba32float 2D array of the image's
    /// size: what a view presents. It is held within the splat's alpha (`aux`'s layer 0) as
    /// [`super::hold_within_splat`] holds it.
    pub fn encode_rgba(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        aux: &wgpu::Texture,
        target: &wgpu::Texture,
    ) -> Result<(), String> {
        let plan = self.plan.as_ref().ok_or("nothing was run")?;
        let [c, h, w] = plan.shapes[self.output];
        let size = target.size();
        if c != 4 || size.width > w || size.height > h {
            return Err(format!(
                "gives [{c}, {h}, {w}]; a {}×{} RGBA picture needs four channels at least that \
                 large",
                size.width, size.height
            ));
        }
        let device = &self.gpu.device;
        let params = OpParams {
            in_c: c,
            in_h: h,
            in_w: w,
            out_c: 4,
            out_h: size.height,
            out_w: size.width,
            kind: super::REACH_PX as u32,
            ..Default::default()
        };
        let uniform = uniform(device, &params);
        let view = crate::render::splatter::array_view(target);
        let aux = crate::render::splatter::array_view(aux);
        let (pipeline, layout) = &self.pipelines.rgba;
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("refine::rgba"),
            layout,
            entries: &[
                entry(0, uniform.as_entire_binding()),
                entry(1, plan.buffers[self.output].as_entire_binding()),
                entry(6, wgpu::BindingResource::TextureView(&aux)),
                entry(8, wgpu::BindingResource::TextureView(&view)),
            ],
        });
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(size.width.div_ceil(8), size.height.div_ceil(8), 1);
        Ok(())
    }

    /// The device it runs on.
    pub fn device(&self) -> &wgpu::Device {
        &self.gpu.device
    }

    fn encoder(&self) -> wgpu::CommandEncoder {
        self.gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("refine"),
            })
    }

    /// Records every step.
    fn encode(&self, encoder: &mut wgpu::CommandEncoder) {
        let plan = self.plan.as_ref().expect("planned");
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("refine"),
            timestamp_writes: None,
        });
        for Dispatch {
            pipeline,
            bind,
            groups,
        } in &plan.dispatches
        {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind, &[]);
            if groups[1] == 0 {
                dispatch_1d(&mut pass, groups[0]);
            } else {
                pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
            }
        }
    }

    /// Submits `encoder` and reads the output back: ([C, H, W], its C).
    pub fn finish(&self, encoder: wgpu::CommandEncoder) -> (Vec<f32>, u32) {
        let plan = self.plan.as_ref().expect("planned");
        self.gpu.queue.submit([encoder.finish()]);
        let [c, h, w] = plan.shapes[self.output];
        let bytes = (c * h * w) as u64 * 4;
        let out = read_buffers(
            &self.gpu.device,
            &self.gpu.queue,
            &[(&plan.buffers[self.output], bytes)],
        );
        (bytemuck::pod_collect_to_vec(&out[0]), c)
    }

    /// The output's [C, H, W] for an input of h×w.
    pub fn output_shape(&mut self, h: u32, w: u32) -> Result<[u32; 3], String> {
        self.plan_for(h, w)?;
        Ok(self.plan.as_ref().expect("planned").shapes[self.output])
    }

    fn plan_for(&mut self, h: u32, w: u32) -> Result<(), String> {
        if self.plan.as_ref().is_some_and(|p| p.size == [w, h]) {
            return Ok(());
        }
        self.plan = None;
        let mut shapes = vec![[0u32; 3]; self.values];
        shapes[self.input] = [self.input_channels, h, w];
        for step in &self.steps {
            step.infer(&mut shapes)?;
        }
        let device = &self.gpu.device;
        let limits = device.limits();
        let most = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        for shape in &shapes {
            let bytes = shape.iter().try_fold(4u64, |n, &d| n.checked_mul(d.into()));
            if bytes.is_none_or(|b| b > most) {
                return Err(format!(
                    "a {h}×{w} input makes a [{}, {}, {}] tensor, more than the device holds in \
                     one buffer ({most} bytes)",
                    shape[0], shape[1], shape[2]
                ));
            }
        }
        let buffers: Vec<_> = shapes
            .iter()
            .map(|[c, h, w]| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("refine::tensor"),
                    size: (u64::from(*c) * u64::from(*h) * u64::from(*w) * 4).max(4),
                    usage: wgpu::BufferUsages::STORAGE
                        | wgpu::BufferUsages::COPY_DST
                        | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                })
            })
            .collect();
        let mut dispatches = Vec::new();
        for step in &self.steps {
            step.dispatches(device, &self.pipelines, &shapes, &buffers, &mut dispatches);
        }
        let max = limits.max_compute_workgroups_per_dimension;
        if let Some(Dispatch { groups, .. }) =
            dispatches.iter().find(|Dispatch { groups: g, .. }| {
                // Flat dispatches ([n, 0, 0]) fold into y themselves.
                (g[1] > 0 && g[0] > max) || g[1] > max || g[2] > max
            })
        {
            return Err(format!(
                "a {h}×{w} input needs {groups:?} workgroups, over {max}"
            ));
        }
        if self.input_channels > max {
            return Err(format!(
                "{} input channels, over {max}",
                self.input_channels
            ));
        }
        self.plan = Some(Plan {
            size: [w, h],
            shapes,
            buffers,
            dispatches,
        });
        Ok(())
    }
}

/// The gather pass's code for the alpha layer (feature layers are their index).
const GATHER_ALPHA: u32 = 0x8000_0000;

fn entry(binding: u32, resource: wgpu::BindingResource<'_>) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource }
}

fn uniform(device: &wgpu::Device, params: &OpParams) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("refine::op"),
        contents: bytemuck::bytes_of(params),
        usage: wgpu::BufferUsages::UNIFORM,
    })
}

impl Step {
    /// Sets this step's output shape from its inputs'.
    fn infer(&self, shapes: &mut [[u32; 3]]) -> Result<(), String> {
        let out = match *self {
            Step::Conv {
                src,
                in_c,
                out_c,
                kernel,
                stride,
                pads,
                ..
            } => {
                let [c, h, w] = shapes[src];
                if c != in_c {
                    return Err(format!("a convolution reads {in_c} channels, gets {c}"));
                }
                let side = |n: u32, k: u32, s: u32, before: u32, after: u32| {
                    (n + before + after)
                        .checked_sub(k)
                        .map(|v| v / s + 1)
                        .ok_or_else(|| format!("the image ({n} px) is smaller than a kernel ({k})"))
                };
                [
                    out_c,
                    side(h, kernel[0], stride[0], pads[0], pads[2])?,
                    side(w, kernel[1], stride[1], pads[1], pads[3])?,
                ]
            }
            Step::Unary { src, .. } => shapes[src],
            Step::Add { a, b, .. } => {
                if shapes[a] != shapes[b] {
                    return Err(format!(
                        "Add of {:?} and {:?} (no broadcasting)",
                        shapes[a], shapes[b]
                    ));
                }
                shapes[a]
            }
            Step::Resize { src, scale, .. } => {
                let [c, h, w] = shapes[src];
                let side = |n: u32, s: f32| {
                    let out = (f64::from(n) * f64::from(s)).floor();
                    if (1.0..=f64::from(u16::MAX)).contains(&out) {
                        Ok(out as u32)
                    } else {
                        Err(format!("resizing {n} px by {s} gives {out} px"))
                    }
                };
                [c, side(h, scale[0])?, side(w, scale[1])?]
            }
            Step::Concat { ref srcs, .. } => {
                let [_, h, w] = shapes[srcs[0]];
                let mut c = 0;
                for &s in srcs {
                    if shapes[s][1..] != [h, w] {
                        return Err(format!(
                            "Concat of {:?} and {:?}",
                            shapes[srcs[0]], shapes[s]
                        ));
                    }
                    c += shapes[s][0];
                }
                [c, h, w]
            }
            Step::Slice {
                src, start, end, ..
            } => {
                let [c, h, w] = shapes[src];
                let (a, b) = slice_range(c, start, end);
                [b - a, h, w]
            }
        };
        shapes[self.dst()] = out;
        Ok(())
    }

    /// The step writing `dst`.
    fn with_dst(mut self, value: Value) -> Self {
        match &mut self {
            Step::Conv { dst, .. }
            | Step::Unary { dst, .. }
            | Step::Add { dst, .. }
            | Step::Resize { dst, .. }
            | Step::Concat { dst, .. }
            | Step::Slice { dst, .. } => *dst = value,
        }
        self
    }

    fn dst(&self) -> Value {
        match *self {
            Step::Conv { dst, .. }
            | Step::Unary { dst, .. }
            | Step::Add { dst, .. }
            | Step::Resize { dst, .. }
            | Step::Concat { dst, .. }
            | Step::Slice { dst, .. } => dst,
        }
    }

    /// This step's dispatches for the planned shapes.
    fn dispatches(
        &self,
        device: &wgpu::Device,
        pipelines: &Pipelines,
        shapes: &[[u32; 3]],
        buffers: &[wgpu::Buffer],
        out: &mut Vec<Dispatch>,
    ) {
        let dst = self.dst();
        let [out_c, out_h, out_w] = shapes[dst];
        let base = OpParams {
            out_c,
            out_h,
            out_w,
            ..Default::default()
        };
        let mut push = |(pipeline, layout): &(wgpu::ComputePipeline, wgpu::BindGroupLayout),
                        params: OpParams,
                        bindings: &[(u32, &wgpu::Buffer)],
                        groups: [u32; 3]| {
            let uniform = uniform(device, &params);
            let mut entries = vec![entry(0, uniform.as_entire_binding())];
            entries.extend(
                bindings
                    .iter()
                    .map(|(i, b)| entry(*i, b.as_entire_binding())),
            );
            let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("refine::step"),
                layout,
                entries: &entries,
            });
            out.push(Dispatch {
                pipeline: pipeline.clone(),
                bind,
                groups,
            });
        };
        let flat = [(out_c * out_h * out_w).div_ceil(64), 0, 0];
        let image = [out_w.div_ceil(8), out_h.div_ceil(8), out_c];
        match self {
            Step::Conv {
                src,
                weights,
                kernel,
                stride,
                pads,
                kind,
                ..
            } => {
                let [in_c, in_h, in_w] = shapes[*src];
                let params = OpParams {
                    in_c,
                    in_h,
                    in_w,
                    kernel_h: kernel[0],
                    kernel_w: kernel[1],
                    stride_h: stride[0],
                    stride_w: stride[1],
                    pad_top: pads[0],
                    pad_left: pads[1],
                    kind: *kind,
                    ..base
                };
                push(
                    &pipelines.conv,
                    params,
                    &[(1, &buffers[*src]), (2, &buffers[dst]), (3, weights)],
                    [
                        out_w.div_ceil(8 * CONV_PIXELS),
                        out_h.div_ceil(8),
                        out_c.div_ceil(4),
                    ],
                );
            }
            Step::Unary {
                src, kind, bounds, ..
            } => {
                let params = OpParams {
                    kind: *kind,
                    lo: bounds[0],
                    hi: bounds[1],
                    ..base
                };
                let io = [(1, &buffers[*src]), (2, &buffers[dst])];
                push(&pipelines.unary, params, &io, flat);
            }
            Step::Add { a, b, .. } => {
                let io = [(1, &buffers[*a]), (2, &buffers[dst]), (4, &buffers[*b])];
                push(&pipelines.add, base, &io, flat);
            }
            Step::Resize { src, scale, .. } => {
                let [in_c, in_h, in_w] = shapes[*src];
                let params = OpParams {
                    in_c,
                    in_h,
                    in_w,
                    scale_h: scale[0],
                    scale_w: scale[1],
                    ..base
                };
                let io = [(1, &buffers[*src]), (2, &buffers[dst])];
                push(&pipelines.resize, params, &io, image);
            }
            Step::Concat { srcs, .. } => {
                let mut at = 0;
                for &s in srcs {
                    let c = shapes[s][0];
                    let params = OpParams {
                        out_c: c,
                        dst_channel: at,
                        ..base
                    };
                    let io = [(1, &buffers[s]), (2, &buffers[dst])];
                    let groups = [(c * out_h * out_w).div_ceil(64), 0, 0];
                    push(&pipelines.copy, params, &io, groups);
                    at += c;
                }
            }
            Step::Slice {
                src, start, end, ..
            } => {
                let (first, _) = slice_range(shapes[*src][0], *start, *end);
                let params = OpParams {
                    src_channel: first,
                    ..base
                };
                let io = [(1, &buffers[*src]), (2, &buffers[dst])];
                push(&pipelines.copy, params, &io, flat);
            }
        }
    }
}

/// ONNX Slice's [start, end) over `n` (negative counts from the end; clamped).
fn slice_range(n: u32, start: i64, end: i64) -> (u32, u32) {
    let at = |i: i64| if i < 0 { (i + n as i64).max(0) } else { i.min(n as i64) } as u32;
    let (a, b) = (at(start), at(end));
    (a, b.max(a))
}

/// Turns nodes into steps.
struct Compiler<'a> {
    device: &'a wgpu::Device,
    model: &'a Model,
    values: HashMap<String, Value>,
    constants: HashMap<String, &'a Tensor>,
    /// How many nodes (and graph outputs) read each value.
    consumers: HashMap<&'a str, usize>,
    steps: Vec<Step>,
    /// Nodes folded into an earlier step (a ReLU after its convolution).
    fused: Vec<usize>,
}

impl<'a> Compiler<'a> {
    fn value(&self, name: &str) -> Result<Value, String> {
        self.values
            .get(name)
            .copied()
            .ok_or_else(|| format!("reads `{name}`, which no earlier node made"))
    }

    fn output(&mut self, name: &str) -> Value {
        let next = self.values.len();
        *self.values.entry(name.to_string()).or_insert(next)
    }

    fn constant(&self, node: &Node, i: usize) -> Result<Option<&'a Tensor>, String> {
        match node.inputs.get(i).map(String::as_str) {
            None | Some("") => Ok(None),
            Some(name) => self
                .constants
                .get(name)
                .copied()
                .map(Some)
                .ok_or_else(|| format!("input {i} (`{name}`) must be a constant here")),
        }
    }

    fn node(&mut self, index: usize, node: &'a Node) -> Result<(), String> {
        if self.fused.contains(&index) {
            return Ok(());
        }
        let out_name = node.outputs.first().ok_or("no output")?;
        if node.op == "Conv" {
            let (step, out_name) = self.conv(index, node)?;
            let dst = self.output(out_name);
            self.steps.push(step.with_dst(dst));
            return Ok(());
        }
        let input = |i: usize| {
            let name = node
                .inputs
                .get(i)
                .ok_or_else(|| format!("input {i} is missing"))?;
            self.value(name)
        };
        let step = match node.op.as_str() {
            "Constant" => {
                let Some(Attribute::Tensor(t)) = node.attributes.get("value") else {
                    return Err("a Constant without a tensor `value`".into());
                };
                self.constants.insert(out_name.clone(), t);
                return Ok(());
            }
            "Relu" | "Sigmoid" => Step::Unary {
                src: input(0)?,
                dst: 0,
                kind: if node.op == "Relu" {
                    UNARY_RELU
                } else {
                    UNARY_SIGMOID
                },
                bounds: [0.0; 2],
            },
            "Clip" => {
                let bound = |i: usize, attr: &str, default: f32| -> Result<f32, String> {
                    if let Some(t) = self.constant(node, i)? {
                        return scalar_f32(t);
                    }
                    Ok(match node.attributes.get(attr) {
                        Some(Attribute::Float(v)) => *v,
                        _ => default,
                    })
                };
                Step::Unary {
                    src: input(0)?,
                    dst: 0,
                    kind: UNARY_CLIP,
                    bounds: [bound(1, "min", f32::MIN)?, bound(2, "max", f32::MAX)?],
                }
            }
            "Add" => Step::Add {
                a: input(0)?,
                b: input(1)?,
                dst: 0,
            },
            "Resize" => Step::Resize {
                src: input(0)?,
                dst: 0,
                scale: resize_scale(node, self.constant(node, 2)?)?,
            },
            "Concat" => {
                if !matches!(node.attributes.get("axis"), Some(Attribute::Int(1 | -3))) {
                    return Err("only concatenation of channels (axis 1) is run".into());
                }
                let srcs = (0..node.inputs.len())
                    .map(input)
                    .collect::<Result<Vec<_>, _>>()?;
                Step::Concat { srcs, dst: 0 }
            }
            "Slice" => {
                let ints = |i: usize| -> Result<Option<Vec<i64>>, String> {
                    match self.constant(node, i)? {
                        Some(Tensor {
                            data: TensorData::I64(v),
                            ..
                        }) => Ok(Some(v.clone())),
                        Some(_) => Err(format!("input {i} is not int64")),
                        None => Ok(None),
                    }
                };
                let (starts, ends) = (ints(1)?.unwrap_or_default(), ints(2)?.unwrap_or_default());
                let axes = ints(3)?.unwrap_or_else(|| vec![0]);
                let steps = ints(4)?.unwrap_or_else(|| vec![1]);
                match (&starts[..], &ends[..], &axes[..], &steps[..]) {
                    ([s], [e], [1 | -3], [1]) => Step::Slice {
                        src: input(0)?,
                        dst: 0,
                        start: *s,
                        end: *e,
                    },
                    _ => {
                        return Err(format!(
                            "only slices of channels with step 1 are run (starts {starts:?}, \
                             ends {ends:?}, axes {axes:?}, steps {steps:?})"
                        ));
                    }
                }
            }
            other => {
                return Err(format!(
                    "the operator {other} is not one the WGSL refiner runs"
                ));
            }
        };
        let dst = self.output(out_name);
        self.steps.push(step.with_dst(dst));
        Ok(())
    }

    /// The convolution's step and the value it writes: its own output, or that of a ReLU that
    /// is its only reader (folded into it).
    fn conv(&mut self, index: usize, node: &'a Node) -> Result<(Step, &'a str), String> {
        let ints = |name: &str, default: &[i64]| -> Result<Vec<i64>, String> {
            match node.attributes.get(name) {
                Some(Attribute::Ints(v)) => Ok(v.clone()),
                None => Ok(default.to_vec()),
                Some(other) => Err(format!("`{name}` is {other:?}")),
            }
        };
        if ints("dilations", &[1, 1])? != [1, 1] {
            return Err("dilated convolutions are not run".into());
        }
        if let Some(Attribute::Int(g)) = node.attributes.get("group")
            && *g != 1
        {
            return Err(format!("grouped convolutions (group {g}) are not run"));
        }
        if let Some(Attribute::String(pad)) = node.attributes.get("auto_pad")
            && pad != "NOTSET"
        {
            return Err(format!("auto_pad {pad} is not run; give explicit pads"));
        }
        let weight = self.constant(node, 1)?.ok_or("no weights")?;
        let TensorData::F32(w) = &weight.data else {
            return Err("weights are not float32".into());
        };
        let [oc, ic, kh, kw] = weight.dims[..] else {
            return Err(format!("weights are {:?}, not [O, I, kH, kW]", weight.dims));
        };
        let (oc, ic, kh, kw) = (oc as usize, ic as usize, kh as usize, kw as usize);
        let bias = match self.constant(node, 2)? {
            Some(Tensor {
                data: TensorData::F32(b),
                ..
            }) if b.len() == oc => b.clone(),
            Some(_) => return Err("the bias is not float32 [O]".into()),
            None => vec![0.0; oc],
        };
        let whole = |v: Vec<i64>| -> Result<Vec<u32>, String> {
            v.iter()
                .map(|&x| u32::try_from(x).map_err(|_| format!("{v:?} out of range")))
                .collect()
        };
        let pads = whole(ints("pads", &[0, 0, 0, 0])?)?;
        let stride = whole(ints("strides", &[1, 1])?)?;
        let (&[p0, p1, p2, p3], &[s0, s1]) = (&pads[..], &stride[..]) else {
            return Err(format!("pads {pads:?} and strides {stride:?} are not 2D"));
        };
        if s0 == 0 || s1 == 0 {
            return Err(format!("a stride of 0 ({stride:?})"));
        }
        // Per four output channels: their biases, then their weights as the shader walks them.
        let taps = ic * kh * kw;
        let groups = oc.div_ceil(4);
        let mut packed = vec![[0.0f32; 4]; groups + groups * taps];
        for o in 0..oc {
            packed[o / 4][o % 4] = bias[o];
            for i in 0..taps {
                packed[groups + (o / 4) * taps + i][o % 4] = w[o * taps + i];
            }
        }
        let weights = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("refine::weights"),
                contents: bytemuck::cast_slice(&packed),
                usage: wgpu::BufferUsages::STORAGE,
            });
        let out = node.outputs.first().ok_or("no output")?;
        let relu = self
            .model
            .nodes
            .iter()
            .enumerate()
            .skip(index + 1)
            .find(|(_, n)| n.op == "Relu" && n.inputs.first() == Some(out))
            .filter(|_| self.consumers.get(out.as_str()) == Some(&1));
        let (kind, written) = match relu {
            Some((j, relu)) => {
                self.fused.push(j);
                (
                    UNARY_RELU,
                    relu.outputs.first().ok_or("a Relu without output")?,
                )
            }
            None => (UNARY_NONE, out),
        };
        let src = self.value(node.inputs.first().ok_or("no input")?)?;
        let step = Step::Conv {
            src,
            dst: 0,
            weights,
            in_c: ic as u32,
            out_c: oc as u32,
            kernel: [kh as u32, kw as u32],
            stride: [s0, s1],
            pads: [p0, p1, p2, p3],
            kind,
        };
        Ok((step, written.as_str()))
    }
}

/// Resize's (y, x) scales: linear, half_pixel, the batch and channels kept.
fn resize_scale(node: &Node, scales: Option<&Tensor>) -> Result<[f32; 2], String> {
    let attr = |name: &str| match node.attributes.get(name) {
        Some(Attribute::String(s)) => s.as_str(),
        _ => "",
    };
    if attr("mode") != "linear" || attr("coordinate_transformation_mode") != "half_pixel" {
        return Err(format!(
            "only linear resizing with half_pixel coordinates is run (mode {:?}, coordinates {:?})",
            attr("mode"),
            attr("coordinate_transformation_mode")
        ));
    }
    match scales {
        Some(Tensor {
            data: TensorData::F32(s),
            ..
        }) if s.len() == 4 && s[0] == 1.0 && s[1] == 1.0 && s[2] > 0.0 && s[3] > 0.0 => {
            Ok([s[2], s[3]])
        }
        other => Err(format!(
            "only constant scales [1, 1, sy, sx] are run (given {other:?}; sizes are not read)"
        )),
    }
}

fn scalar_f32(t: &Tensor) -> Result<f32, String> {
    match &t.data {
        TensorData::F32(v) if v.len() == 1 => Ok(v[0]),
        _ => Err(format!("{t:?} is not one float")),
    }
}
