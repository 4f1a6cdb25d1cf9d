//! One view's frame path on a device it shares with a UI (the viewer's viewport, drawn by an egui
//! paint callback). The long-lived passes (splatting, rig, present, mesh) live here once; what to
//! draw arrives each frame as a [`Frame`], owned and cheap to clone, so a UI builds one per view
//! and hands it over. [`ViewRenderer::prepare`] records work only for what changed since the last
//! render — a cloud or an avatar goes up once, a new pose runs the rig pass, a new camera or
//! background re-splats — and reads the splatting counters back without waiting (a frame later);
//! [`ViewRenderer::paint`] only composites. The refiner is a pass on the same frame
//! ([`refined`]).

mod refined;

pub use refined::{RefineReport, RefineWith};

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use glam::Vec3;

use crate::avatar::{Avatar, HandsInView};
use crate::body::PosedBody;
use crate::camera::Camera;
use crate::gaussians::GaussianCloud;
use crate::render::mesh::{MeshPass, MeshStyle};
use crate::render::present::{PresentMode, PresentPass, PresentUniform};
use crate::render::splatter::STATS_BYTES;
use crate::render::{GpuAvatar, RasterTuning, RenderStats, SplatPipelines, Splatter, StageTimer};
use refined::{RefineStage, Showing};

/// What one view draws this frame.
#[derive(Clone)]
pub struct Frame {
    pub content: Content,
    pub camera: Camera,
    /// Splat at this fraction of the camera's resolution (1 = full): a UI lowers it while the
    /// user drags or plays, to keep up, and goes back to 1 when input settles.
    pub scale: f32,
    /// Draw an avatar's coarse stand-in ([`Avatar::preview`]) instead of all its Gaussians, as
    /// a UI does while the user drags or plays.
    pub preview: bool,
    /// Which pane of the view this is (below [`PANES`]): the sides of a split present the same
    /// splats each its own way (its [`Look`]'s display), each pane drawn by its own callback.
    pub pane: usize,
    /// Present an avatar's frame refined (by [`RefineWith`]'s refiner) once its picture is
    /// made; the raw splat meanwhile.
    pub refine: Option<RefineWith>,
}

/// Panes a view presents at once (a split's two sides).
pub const PANES: usize = 2;

#[derive(Clone)]
pub enum Content {
    /// A Gaussian cloud as it is (a splat file, a test scene).
    Cloud { cloud: CloudRef, look: Look },
    /// An avatar posed on its body, posed on the GPU; with `outside`, the parts its photo did
    /// not show too (neutral grey).
    Avatar {
        avatar: AvatarRef,
        pose: PoseRef,
        look: Look,
        outside: bool,
    },
    /// A posed body as a mesh.
    Mesh(MeshFrame),
}

/// A cloud and the id it goes by: each id is uploaded once.
#[derive(Clone)]
pub struct CloudRef {
    pub id: u64,
    pub cloud: Arc<GaussianCloud>,
}

/// An avatar with its body's triangles and seam weld, and the id it goes by: each id is
/// uploaded once.
#[derive(Clone)]
pub struct AvatarRef {
    pub id: u64,
    pub avatar: Arc<Avatar>,
    pub triangles: Arc<Vec<[u32; 3]>>,
    pub weld: Option<Arc<Vec<u32>>>,
    /// Its hands the photo did not show, drawn only where the photo looked.
    pub hands: Option<Arc<HandsInView>>,
}

impl AvatarRef {
    /// `avatar` (this one, or its coarse stand-in) on the GPU for `pipelines`, bound to this
    /// body's mesh and drawing the hands its photo did not show only where it looked.
    pub fn upload(
        &self,
        device: &wgpu::Device,
        pipelines: Arc<SplatPipelines>,
        avatar: &Avatar,
    ) -> GpuAvatar {
        let weld = self.weld.as_deref().map(Vec::as_slice);
        let mut gpu = GpuAvatar::new(device, pipelines, avatar, &self.triangles, weld);
        gpu.set_hands(self.hands.clone());
        gpu
    }
}

/// A posed body and the id of that pose: each id is rigged once.
#[derive(Clone)]
pub struct PoseRef {
    pub id: u64,
    pub posed: Arc<PosedBody>,
}

/// A posed body for the mesh view. `topology` changes with the body model, `pose` with every
/// re-pose, so each is uploaded once.
#[derive(Clone)]
pub struct MeshFrame {
    pub topology: u64,
    pub pose: u64,
    pub triangles: Arc<Vec<[u32; 3]>>,
    pub positions: Arc<Vec<Vec3>>,
    pub normals: Arc<Vec<Vec3>>,
    pub style: MeshStyle,
}

/// How splats are shown: the background (one value per channel; the displayed ones are
/// composited under the splats by the present pass) and the present mode.
#[derive(Clone, Debug, PartialEq)]
pub struct Look {
    pub background: Vec<f32>,
    pub display: Display,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Display {
    pub mode: PresentMode,
    pub rgb_channels: [u32; 3],
    pub inv_depth_range: [f32; 2],
}

impl Default for Display {
    fn default() -> Self {
        Self {
            mode: PresentMode::Rgb,
            rgb_channels: [0, 1, 2],
            inv_depth_range: [0.0, 1.0],
        }
    }
}

/// What the view tells its UI.
#[derive(Clone, Debug, Default)]
pub struct ViewReport {
    /// The last splatting counters that came back.
    pub stats: Option<RenderStats>,
    /// Frames the splatting pass ran (it is skipped when nothing changed).
    pub renders: u64,
    /// Rig passes run (one per new pose of an avatar).
    pub rigs: u64,
    /// The size the last splat was rendered at.
    pub rendered_size: [u32; 2],
    /// Set when another frame is needed (the counters are on their way back, or buffers grew):
    /// the UI requests a repaint and clears it.
    pub needs_redraw: bool,
    /// Content the GPU could not take (too large for the adapter, or posed on another body);
    /// the UI shows it once and clears it.
    pub error: Option<String>,
    /// GPU time of each splatting stage ([`Stage::ALL`] order, ms) of the last frame whose
    /// counters came back; `None` where the adapter has no timestamps.
    pub stage_ms: Option<Vec<f64>>,
    /// CPU time of the last frame's prepare: rig upload, splat uniforms, command encoding (ms).
    pub prepare_ms: f32,
    /// GPU memory the splatting pass holds (bytes).
    pub splat_bytes: u64,
    /// Avatars uploaded to the GPU (all Gaussians, or a coarse stand-in): each once while shown.
    pub avatar_uploads: u64,
    pub refine: RefineReport,
}

/// Where the stage times follow the splat counters in the readback buffer: 8-byte aligned (they
/// are read as u64).
const TIMES_AT: u64 = STATS_BYTES.next_multiple_of(8);

/// Which splat input the splatter holds.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Source {
    Cloud(u64),
    Avatar {
        id: u64,
        preview: bool,
        outside: bool,
    },
}

/// What the splat output shows. The splats are rendered on black (the background is
/// composited when presenting), so one output serves every pane and the refiner.
#[derive(Clone, PartialEq)]
struct SplatKey {
    source: Source,
    pose: Option<u64>,
    camera: Camera,
}

#[derive(PartialEq)]
struct MeshKey {
    pose: u64,
    camera: Camera,
    style: MeshStyle,
}

/// The avatar on the GPU: all its Gaussians, and its stand-in for interaction once needed.
struct ShownAvatar {
    id: u64,
    full: GpuAvatar,
    preview: Option<GpuAvatar>,
}

/// The stats buffer's way back: copied into staging with a render, mapped a frame later —
/// when the pane that copied it prepares again (each pane prepares once per UI frame, and what
/// one frame recorded is submitted before the next).
enum StatsReadback {
    Idle,
    Copied { pane: usize },
    Mapping(Arc<AtomicBool>),
}

/// One pane's present settings and its bindings of the splat output and the refined picture,
/// and which one it presents.
struct Pane {
    uniform: wgpu::Buffer,
    bind: Option<wgpu::BindGroup>,
    /// Made for the picture texture of this generation ([`RefineStage::generation`]).
    refined_bind: Option<(u64, wgpu::BindGroup)>,
    refined: bool,
}

pub struct ViewRenderer {
    pipelines: Arc<SplatPipelines>,
    splatter: Splatter,
    /// The splatter's current input; an avatar (and its coarse stand-in, once used) is kept on
    /// the GPU while it is shown.
    source: Option<Source>,
    avatar: Option<ShownAvatar>,
    rigged: Option<(Source, u64)>,
    last: Option<SplatKey>,
    present: PresentPass,
    panes: [Pane; PANES],
    /// The splat counters (32 bytes), then the stage timestamps where the device has them.
    stats_staging: wgpu::Buffer,
    stats_state: StatsReadback,
    timer: Option<StageTimer>,
    mesh: MeshPass,
    mesh_topology: Option<u64>,
    mesh_uploaded: Option<u64>,
    mesh_last: Option<MeshKey>,
    refine: RefineStage,
}

impl ViewRenderer {
    /// The passes for a device (its rasterizer tuned to `adapter`), drawing into `target`.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        adapter: &wgpu::AdapterInfo,
        target: wgpu::TextureFormat,
    ) -> Self {
        let pipelines = Arc::new(SplatPipelines::new(
            device,
            RasterTuning::for_device(adapter, device.features()),
        ));
        Self::with_pipelines(device, queue, pipelines, target)
    }

    /// With splatting pipelines shared with other renderers on the device.
    pub fn with_pipelines(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipelines: Arc<SplatPipelines>,
        target: wgpu::TextureFormat,
    ) -> Self {
        let timer = StageTimer::new(device, queue);
        Self {
            splatter: Splatter::new(device, pipelines.clone()),
            pipelines,
            source: None,
            avatar: None,
            rigged: None,
            last: None,
            present: PresentPass::new(device, target),
            panes: std::array::from_fn(|_| Pane {
                uniform: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("View::present_uniform"),
                    size: size_of::<PresentUniform>() as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                bind: None,
                refined_bind: None,
                refined: false,
            }),
            stats_staging: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("View::stats_staging"),
                size: TIMES_AT + timer.as_ref().map_or(0, StageTimer::resolved_size),
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
            stats_state: StatsReadback::Idle,
            timer,
            mesh: MeshPass::new(device, Some(target)),
            mesh_topology: None,
            mesh_uploaded: None,
            mesh_last: None,
            refine: RefineStage::new(),
        }
    }

    /// The splatting pipelines, to share with other renderers on the device.
    pub fn pipelines(&self) -> Arc<SplatPipelines> {
        self.pipelines.clone()
    }

    /// Records what `frame` needs beyond the last render, if anything (submit in order).
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &Frame,
        report: &mut ViewReport,
    ) -> Vec<wgpu::CommandBuffer> {
        let started = std::time::Instant::now();
        let mut commands = Vec::new();
        self.prepare_content(device, queue, frame, report, &mut commands);
        if !commands.is_empty() {
            report.prepare_ms = started.elapsed().as_secs_f32() * 1e3;
        }
        commands
    }

    fn prepare_content(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &Frame,
        report: &mut ViewReport,
        commands: &mut Vec<wgpu::CommandBuffer>,
    ) {
        match &frame.content {
            Content::Mesh(mesh) => {
                commands.extend(self.prepare_mesh(device, queue, mesh, &frame.camera, report));
            }
            Content::Cloud { cloud, look } => {
                let source = Source::Cloud(cloud.id);
                if self.source != Some(source) {
                    self.source = Some(source);
                    self.last = None;
                    self.detach_avatar();
                    if let Err(e) = self.splatter.upload(device, queue, &cloud.cloud) {
                        report.error = Some(e.to_string());
                    }
                }
                self.prepare_splats(device, queue, None, false, frame, look, report, commands);
            }
            Content::Avatar {
                avatar,
                pose,
                look,
                outside,
            } => {
                let source = Source::Avatar {
                    id: avatar.id,
                    preview: frame.preview,
                    outside: *outside,
                };
                if self.avatar.as_ref().is_none_or(|a| a.id != avatar.id) {
                    report.avatar_uploads += 1;
                    self.avatar = Some(ShownAvatar {
                        id: avatar.id,
                        full: avatar.upload(device, self.pipelines.clone(), &avatar.avatar),
                        preview: None,
                    });
                }
                if self.source != Some(source) {
                    self.source = Some(source);
                    self.last = None;
                    self.detach_avatar();
                }
                let shown = self.avatar.as_mut().expect("made above");
                let gpu = match frame.preview {
                    true => shown.preview.get_or_insert_with(|| {
                        report.avatar_uploads += 1;
                        avatar.upload(device, self.pipelines.clone(), &avatar.avatar.preview())
                    }),
                    false => &mut shown.full,
                };
                gpu.show_outside(queue, *outside);
                if let Err(e) = gpu.attach(device, queue, &mut self.splatter) {
                    report.error = Some(e.to_string());
                    return;
                }
                let mut new_pose = false;
                if self.rigged != Some((source, pose.id)) {
                    // Marked either way: a pose the avatar cannot take is reported once.
                    self.rigged = Some((source, pose.id));
                    match gpu.set_pose(queue, &pose.posed) {
                        Ok(()) => new_pose = true,
                        Err(e) => report.error = Some(e.to_string()),
                    }
                }
                let pose = Some(pose.id);
                self.prepare_splats(device, queue, pose, new_pose, frame, look, report, commands);
            }
        }
    }

    /// Forgets which avatar's Gaussians the splatter holds (something else takes their place).
    fn detach_avatar(&mut self) {
        if let Some(shown) = &mut self.avatar {
            shown.full.detach();
            if let Some(preview) = &mut shown.preview {
                preview.detach();
            }
        }
    }

    /// Re-splats when the input, pose or camera changed (running the rig pass first for a
    /// `new_pose`), refines where the frame asks; updates the pane's present uniform either way.
    #[allow(clippy::too_many_arguments)]
    fn prepare_splats(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pose: Option<u64>,
        new_pose: bool,
        frame: &Frame,
        look: &Look,
        report: &mut ViewReport,
        commands: &mut Vec<wgpu::CommandBuffer>,
    ) {
        let pane = frame.pane.min(PANES - 1);
        if let Some((stats, stage_ms)) = self.poll_stats(device, pane) {
            if self.splatter.grow_for(device, &stats) {
                self.last = None;
                report.needs_redraw = true;
            }
            report.stats = Some(stats);
            report.stage_ms = stage_ms;
        }
        report.splat_bytes = self.splatter.memory().total();
        let camera = frame.camera.scaled(frame.scale);
        let Some(source) = self.source else { return };
        let key = SplatKey {
            source,
            pose,
            camera,
        };
        if let Some(channels) = self.splatter.channels()
            && self.last.as_ref() != Some(&key)
        {
            self.splatter
                .prepare(device, queue, &camera, &vec![0.0; channels as usize]);
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("View::splat"),
            });
            if new_pose && let Some(shown) = &self.avatar {
                let preview = matches!(self.source, Some(Source::Avatar { preview: true, .. }));
                let gpu = match (preview, &shown.preview) {
                    (true, Some(p)) => p,
                    _ => &shown.full,
                };
                gpu.encode(&mut encoder);
                report.rigs += 1;
            }
            // Timed (where the device can) on the frames whose counters are read back.
            let read_back = matches!(self.stats_state, StatsReadback::Idle);
            let timer = self.timer.as_ref().filter(|_| read_back);
            self.splatter.encode(&mut encoder, timer);
            if read_back {
                encoder.copy_buffer_to_buffer(
                    self.splatter.stats_buffer(),
                    0,
                    &self.stats_staging,
                    0,
                    STATS_BYTES,
                );
                if let Some(timer) = timer {
                    timer.resolve(&mut encoder);
                    timer.copy_resolved(&mut encoder, &self.stats_staging, TIMES_AT);
                }
                self.stats_state = StatsReadback::Copied { pane };
            }
            commands.push(encoder.finish());
            // Every pane presents the new output (the splatter may have reallocated it).
            for p in &mut self.panes {
                p.bind = self.present.bind(device, &p.uniform, &self.splatter);
                p.refined_bind = None;
            }
            self.last = Some(key.clone());
            report.renders += 1;
            report.rendered_size = [camera.width, camera.height];
        } else if !matches!(self.stats_state, StatsReadback::Idle) {
            report.needs_redraw = true;
        }
        let showing = match &frame.refine {
            Some(with) if pose.is_some() && self.last.as_ref() == Some(&key) => {
                let stage = &mut self.refine;
                stage.prepare(
                    device,
                    queue,
                    &self.splatter,
                    &key,
                    with,
                    pane,
                    commands,
                    report,
                )
            }
            _ => Showing::Raw,
        };
        let d = &look.display;
        let background = d
            .rgb_channels
            .map(|c| look.background.get(c as usize).copied());
        let background = background.map(|b| b.unwrap_or(0.0));
        let uniform = match showing {
            Showing::Refined(size) => self.present.refined_uniform(size, background),
            Showing::Raw => self.present.uniform(
                [camera.width, camera.height],
                d.mode,
                d.rgb_channels,
                d.inv_depth_range,
                background,
            ),
        };
        let p = &mut self.panes[pane];
        p.refined = matches!(showing, Showing::Refined(_));
        let generation = self.refine.generation();
        if p.refined
            && p.refined_bind
                .as_ref()
                .is_none_or(|(g, _)| *g != generation)
        {
            // A new picture texture, or a new splat output: bind them again.
            let texture = self.refine.texture().expect("a picture is shown");
            p.refined_bind = self
                .present
                .bind_refined(device, &p.uniform, texture, &self.splatter)
                .map(|bind| (generation, bind));
        }
        queue.write_buffer(&p.uniform, 0, bytemuck::bytes_of(&uniform));
    }

    /// Re-draws the mesh view when the pose, camera or style changed.
    fn prepare_mesh(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        body: &MeshFrame,
        camera: &Camera,
        report: &mut ViewReport,
    ) -> Option<wgpu::CommandBuffer> {
        if self.mesh_topology != Some(body.topology) {
            self.mesh
                .set_topology(device, body.positions.len(), &body.triangles);
            self.mesh_topology = Some(body.topology);
            // A new body: its first pose id may equal the old body's last one.
            self.mesh_uploaded = None;
            self.mesh_last = None;
        }
        if self.mesh_uploaded != Some(body.pose) {
            self.mesh
                .set_vertices(queue, &body.positions, &body.normals);
            self.mesh_uploaded = Some(body.pose);
        }
        let key = MeshKey {
            pose: body.pose,
            camera: *camera,
            style: body.style,
        };
        if self.mesh_last.as_ref() == Some(&key) {
            return None;
        }
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("View::mesh"),
        });
        self.mesh
            .encode(device, queue, &mut encoder, camera, &body.style);
        self.mesh_last = Some(key);
        report.renders += 1;
        report.rendered_size = [camera.width, camera.height];
        Some(encoder.finish())
    }

    /// Advances the non-blocking stats readback; returns the counters (and the stage times,
    /// where timed) when a copy has landed.
    fn poll_stats(
        &mut self,
        device: &wgpu::Device,
        pane: usize,
    ) -> Option<(RenderStats, Option<Vec<f64>>)> {
        match &self.stats_state {
            StatsReadback::Idle => None,
            // Copied by another pane this UI frame: not submitted yet.
            StatsReadback::Copied { pane: copied } if *copied != pane => None,
            StatsReadback::Copied { .. } => {
                // The copy was submitted last frame: now the buffer may be mapped.
                let done = Arc::new(AtomicBool::new(false));
                let flag = done.clone();
                self.stats_staging
                    .slice(..)
                    .map_async(wgpu::MapMode::Read, move |r| {
                        flag.store(r.is_ok(), Ordering::Release)
                    });
                self.stats_state = StatsReadback::Mapping(done);
                None
            }
            StatsReadback::Mapping(done) => {
                let _ = device.poll(wgpu::PollType::Poll);
                if !done.load(Ordering::Acquire) {
                    return None;
                }
                let bytes: Vec<u8> = self
                    .stats_staging
                    .slice(..)
                    .get_mapped_range()
                    .map(|v| v.to_vec())
                    .unwrap_or_default();
                self.stats_staging.unmap();
                self.stats_state = StatsReadback::Idle;
                if bytes.len() < TIMES_AT as usize {
                    return None;
                }
                let (words, ticks) = bytes.split_at(TIMES_AT as usize);
                let stats = RenderStats::from_words(
                    self.splatter.num_gaussians(),
                    bytemuck::cast_slice(&words[..STATS_BYTES as usize]),
                );
                let stage_ms = self
                    .timer
                    .as_ref()
                    .map(|t| t.ms(bytemuck::cast_slice(ticks)));
                Some((stats, stage_ms))
            }
        }
    }

    /// Composites what [`Self::prepare`] last rendered for `frame`'s content.
    pub fn paint(&self, pass: &mut wgpu::RenderPass<'static>, frame: &Frame) {
        match &frame.content {
            Content::Cloud { .. } | Content::Avatar { .. } => {
                let pane = &self.panes[frame.pane.min(PANES - 1)];
                let bind = match pane.refined {
                    true => pane.refined_bind.as_ref().map(|(_, b)| b),
                    false => pane.bind.as_ref(),
                };
                if let Some(bind) = bind {
                    self.present.draw(pass, bind);
                }
            }
            Content::Mesh(_) => self.mesh.draw_blit(pass),
        }
    }

    /// GPU memory the shown avatar's own buffers hold (all Gaussians, and the coarse stand-in
    /// once used).
    pub fn avatar_bytes(&self) -> u64 {
        self.avatar.as_ref().map_or(0, |a| {
            a.full.gpu_bytes() + a.preview.as_ref().map_or(0, GpuAvatar::gpu_bytes)
        })
    }

    /// GPU memory the splatting pass holds (for the HUD).
    pub fn memory(&self) -> crate::render::splatter::MemoryUse {
        self.splatter.memory()
    }
}
