//! `#[repr(C)]` mirrors of the WGSL structs in shaders/common.wgsl and the pass files. The test
//! `wgsl_layouts_match_rust` (tests/shaders.rs) reflects the WGSL with naga and fails on any drift.

use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniform {
    pub view_from_world: [[f32; 4]; 4],
    pub focal: [f32; 2],
    pub principal: [f32; 2],
    pub ewa_lim: [f32; 4],
    pub size: [u32; 2],
    pub tiles: [u32; 2],
    pub near: f32,
    pub num_gaussians: u32,
    pub pair_capacity: u32,
    pub channels: u32,
    /// [`crate::gaussians::LowPass`]: 0 dilated, 1 compensated.
    pub low_pass: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}
const _: () = assert!(size_of::<FrameUniform>() == 144);

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuGaussian {
    pub pos: [f32; 3],
    pub opacity: f32,
    pub rot: [f32; 4],
    pub scale: [f32; 3],
    pub _pad: f32,
}
const _: () = assert!(size_of::<GpuGaussian>() == 48);

/// Written by preprocess, read by binning and rasterization; never touched by the CPU.
pub const PROJECTED_SIZE: u64 = 48;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ScanParams {
    pub count: u32,
    pub num_blocks: u32,
    pub total_index: u32,
    pub _pad: u32,
}
const _: () = assert!(size_of::<ScanParams>() == 16);

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct SortPass {
    pub shift: u32,
    pub num_blocks: u32,
    pub count_index: u32,
    pub _pad: u32,
}
const _: () = assert!(size_of::<SortPass>() == 16);

/// shaders/rig.wgsl: the counts of the three Gaussian sets and of the mesh's triangles.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct RigParams {
    pub template_count: u32,
    pub uv_count: u32,
    pub triangle_count: u32,
    pub skinned_count: u32,
}
const _: () = assert!(size_of::<RigParams>() == 16);

/// A template Gaussian in its vertex's skinning frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct TemplateGaussian {
    pub rot: [f32; 4],
    pub scale: [f32; 3],
    pub opacity: f32,
}
const _: () = assert!(size_of::<TemplateGaussian>() == 32);

/// A UV Gaussian bound to its triangle.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct UvGaussian {
    pub bary: [f32; 3],
    pub triangle: u32,
    pub offset: [f32; 3],
    pub opacity: f32,
    pub rot: [f32; 4],
    pub scale: [f32; 3],
    pub _pad: f32,
}
const _: () = assert!(size_of::<UvGaussian>() == 64);

/// A skinned Gaussian bound to up to four vertices.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct SkinnedGaussian {
    pub vertices: [u32; 4],
    pub weights: [f32; 4],
    pub offset: [f32; 3],
    pub opacity: f32,
    pub rot: [f32; 4],
    pub scale: [f32; 3],
    pub _pad: f32,
}
const _: () = assert!(size_of::<SkinnedGaussian>() == 80);

/// A posed vertex: its position (w: 1 where it is drawn, 0 on a hand out of the photo's view,
/// [`crate::avatar::HandsInView`]) and the linear part of its skinning transform (columns, each
/// padded to four floats as WGSL's `mat3x3<f32>` is).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct PosedVertex {
    pub position: [f32; 4],
    pub skin: [[f32; 4]; 3],
}
const _: () = assert!(size_of::<PosedVertex>() == 64);

/// shaders/rig.wgsl's `TriangleFrame`: written by the rig's frames pass, read by its UV pass;
/// never touched by the CPU.
pub const TRIANGLE_FRAME_SIZE: u64 = 64;
