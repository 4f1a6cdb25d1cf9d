//! The refiner as a pass on the view's own frame: the splat image already on the GPU is refined
//! into a picture the present pass composites over the background — no second renderer, no
//! second copy of the avatar. Where the refiner runs on this device as our WGSL passes (a
//! default refiner on a hardware adapter), it is recorded with the frame and reads the splat
//! layers where they lie; otherwise (ONNX Runtime on the CPU) the splat image is copied to
//! staging with the frame, read and refined on a worker while the UI goes on, and the picture
//! uploaded when it is back.

use std::path::PathBuf;
use std::sync::mpsc::{Receiver, TryRecvError};
use std::sync::{Arc, Mutex, TryLockError};
use std::time::Instant;

use super::{SplatKey, ViewReport};
use crate::refine::{RefinerOn, SharedRefiner};
use crate::render::splatter::ImageCopy;
use crate::render::{SplatImage, Splatter, wait};

/// What a view refines its frame with.
#[derive(Clone)]
pub struct RefineWith {
    /// The refiner, loaded by the UI (shared with its workers and exports): the view waits
    /// while it holds another or none, or is busy elsewhere.
    pub refiner: SharedRefiner,
    /// The model file and where it runs, as the refiner must be.
    pub path: PathBuf,
    pub on: RefinerOn,
    /// While the next picture is made, show the latest one though it was made for an earlier
    /// frame (the user drags or plays with refining on).
    pub behind: bool,
    /// Called from the worker when a picture from the CPU refiner is ready (a UI asks for a
    /// frame), so nothing polls meanwhile.
    pub wake: Option<Arc<dyn Fn() + Send + Sync>>,
}

/// What the view tells its UI of the refiner.
#[derive(Clone, Debug, Default)]
pub struct RefineReport {
    /// Refined pictures shown so far.
    pub frames: u64,
    /// Where the last one was refined (`Refiner::engine_name`), and the time from the frame
    /// asking for it to its picture on the GPU (ms): a readback, the CPU refiner and an upload;
    /// `None` where it was recorded with the frame (the GPU's own time, not measured here).
    pub engine: Option<String>,
    pub ms: Option<f32>,
    /// Whether the last frame asking for a refined picture showed one, and whether that was
    /// an earlier frame's.
    pub showing: bool,
    pub behind: bool,
    /// The refiner failed (the UI shows it once and clears it).
    pub error: Option<String>,
}

/// What a refined picture shows: it is current while the splat and the refiner are unchanged.
#[derive(Clone, PartialEq)]
struct Made {
    splat: SplatKey,
    path: PathBuf,
    on: RefinerOn,
}

/// What the present pass shows for a pane asking for the refined picture.
pub(super) enum Showing {
    /// The raw splat (no picture yet).
    Raw,
    /// The refined picture, of the given size.
    Refined([u32; 2]),
}

/// A picture on its way back from the CPU refiner, and where it was made; `None` where the
/// refiner changed before it ran.
type Outcome = Result<Option<(SplatImage, String)>, String>;

enum Work {
    Idle,
    /// The splat image copied to staging by `pane`'s command buffer, submitted once that pane
    /// prepares again (each pane prepares once per UI frame).
    Copied {
        made: Made,
        copy: ImageCopy,
        refiner: SharedRefiner,
        wake: Option<Arc<dyn Fn() + Send + Sync>>,
        pane: usize,
        asked: Instant,
    },
    /// Read back and refined on a worker (the receiver in a mutex: a view is shared between
    /// threads, though only the UI's uses it).
    Refining {
        made: Made,
        rx: Mutex<Receiver<Outcome>>,
        asked: Instant,
    },
}

pub(super) struct RefineStage {
    /// The latest refined picture (rgba32float, one layer: premultiplied RGB and alpha) and
    /// what it shows.
    picture: Option<(wgpu::Texture, Made)>,
    /// Counts the picture textures made, so bindings of an old one are renewed.
    generation: u64,
    work: Work,
}

impl RefineStage {
    pub fn new() -> Self {
        Self {
            picture: None,
            generation: 0,
            work: Work::Idle,
        }
    }

    /// Which picture texture [`Self::texture`] is.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The refined picture's texture, once there is one.
    pub fn texture(&self) -> Option<&wgpu::Texture> {
        self.picture.as_ref().map(|(t, _)| t)
    }

    /// Advances the refinement of `splat` (the splatter's current output) for `pane`, recording
    /// any GPU work into `commands`; returns what to present.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        splatter: &Splatter,
        splat: &SplatKey,
        with: &RefineWith,
        pane: usize,
        commands: &mut Vec<wgpu::CommandBuffer>,
        report: &mut ViewReport,
    ) -> Showing {
        let wanted = Made {
            splat: splat.clone(),
            path: with.path.clone(),
            on: with.on,
        };
        self.advance(device, queue, &wanted, with.behind, pane, report);
        if self.current(&wanted).is_none() && matches!(self.work, Work::Idle) {
            self.start(
                device,
                splatter,
                wanted.clone(),
                with,
                pane,
                commands,
                report,
            );
        }
        let showing = match (self.current(&wanted), &self.picture) {
            (Some(size), _) => Some((size, false)),
            (None, Some((texture, _))) if with.behind => Some((size_of(texture), true)),
            _ => None,
        };
        report.refine.showing = showing.is_some();
        report.refine.behind = showing.is_some_and(|(_, behind)| behind);
        match showing {
            Some((size, _)) => Showing::Refined(size),
            None => Showing::Raw,
        }
    }

    /// The picture's size if it shows `wanted`.
    fn current(&self, wanted: &Made) -> Option<[u32; 2]> {
        let (texture, made) = self.picture.as_ref()?;
        (made == wanted).then(|| size_of(texture))
    }

    /// Moves CPU work along: hands a submitted copy to a worker, takes a finished picture.
    fn advance(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        wanted: &Made,
        behind: bool,
        pane: usize,
        report: &mut ViewReport,
    ) {
        match std::mem::replace(&mut self.work, Work::Idle) {
            Work::Idle => {}
            Work::Copied {
                made,
                copy,
                refiner,
                wake,
                pane: copied,
                asked,
            } if copied == pane => {
                let (tx, rx) = std::sync::mpsc::channel();
                let (device, path, on) = (device.clone(), made.path.clone(), made.on);
                std::thread::spawn(move || {
                    copy.map();
                    wait(&device);
                    let image = copy.image();
                    let mut guard = refiner.lock().unwrap_or_else(|e| e.into_inner());
                    let refined = match guard.as_mut() {
                        Some(r) if r.path == path && r.on == on => r
                            .refine(&image)
                            .map(|p| Some((p, r.engine_name().to_string())))
                            .map_err(|e| e.to_string()),
                        _ => Ok(None),
                    };
                    // The receiver is gone if the view was dropped: nothing to do then.
                    let _ = tx.send(refined);
                    if let Some(wake) = wake {
                        wake();
                    }
                });
                self.work = Work::Refining {
                    made,
                    rx: Mutex::new(rx),
                    asked,
                };
            }
            copied @ Work::Copied { .. } => {
                // Copied by another pane this UI frame: not submitted yet.
                self.work = copied;
                report.needs_redraw = true;
            }
            Work::Refining { made, rx, asked } => match try_recv(&rx) {
                // The worker wakes the UI when it is done.
                Err(TryRecvError::Empty) => self.work = Work::Refining { made, rx, asked },
                Ok(Ok(Some((picture, engine)))) if made == *wanted || behind => {
                    self.upload(device, queue, &picture, made);
                    report.refine.frames += 1;
                    report.refine.engine = Some(engine);
                    report.refine.ms = Some(asked.elapsed().as_secs_f32() * 1e3);
                    report.needs_redraw = true;
                }
                Ok(Err(e)) => report.refine.error = Some(e),
                // Stale (the view changed meanwhile, and nothing earlier is shown), or the
                // worker is gone.
                _ => report.needs_redraw = true,
            },
        }
    }

    /// Starts refining the splatter's output as `made`: recorded with the frame where the
    /// refiner runs on this device, else copied for the CPU refiner.
    #[allow(clippy::too_many_arguments)]
    fn start(
        &mut self,
        device: &wgpu::Device,
        splatter: &Splatter,
        made: Made,
        with: &RefineWith,
        pane: usize,
        commands: &mut Vec<wgpu::CommandBuffer>,
        report: &mut ViewReport,
    ) {
        let mut guard = match with.refiner.try_lock() {
            Ok(guard) => guard,
            Err(TryLockError::Poisoned(e)) => e.into_inner(),
            // Loading, or refining an export: try again next frame.
            Err(TryLockError::WouldBlock) => {
                report.needs_redraw = true;
                return;
            }
        };
        let Some(refiner) = guard
            .as_mut()
            .filter(|r| r.path == with.path && r.on == with.on)
        else {
            // Not loaded yet (the UI loads it).
            report.needs_redraw = true;
            return;
        };
        let Some(features) = splatter.features() else {
            return;
        };
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("View::refine"),
        });
        if refiner.runs_on(device) {
            let size = [features.width(), features.height()];
            let texture = self.texture_for(device, size);
            match refiner.encode_into(&mut encoder, device, splatter, &texture) {
                Ok(true) => {
                    commands.push(encoder.finish());
                    self.picture = Some((texture, made));
                    report.refine.frames += 1;
                    report.refine.engine = Some(refiner.engine_name().to_string());
                    report.refine.ms = None;
                }
                Ok(false) => {}
                Err(e) => report.refine.error = Some(e.to_string()),
            }
            return;
        }
        if let Some(copy) = splatter.copy_image(device, &mut encoder) {
            commands.push(encoder.finish());
            self.work = Work::Copied {
                made,
                copy,
                refiner: with.refiner.clone(),
                wake: with.wake.clone(),
                pane,
                asked: Instant::now(),
            };
            report.needs_redraw = true;
        }
    }

    /// The picture's texture at `size`: the current one if it has that size (its picture is
    /// replaced), else a new one.
    fn texture_for(&mut self, device: &wgpu::Device, size: [u32; 2]) -> wgpu::Texture {
        match self.picture.take() {
            Some((texture, _)) if size_of(&texture) == size => texture,
            _ => {
                self.generation += 1;
                device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("View::refined"),
                    size: wgpu::Extent3d {
                        width: size[0],
                        height: size[1],
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba32Float,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING
                        | wgpu::TextureUsages::STORAGE_BINDING
                        | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                })
            }
        }
    }

    /// Puts a picture from the CPU refiner (RGB on black and alpha) on the GPU.
    fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, p: &SplatImage, made: Made) {
        let texture = self.texture_for(device, [p.width, p.height]);
        let n = p.width as usize * p.height as usize;
        let texels: Vec<f32> = (0..n)
            .flat_map(|i| [p.plane(0)[i], p.plane(1)[i], p.plane(2)[i], p.alpha[i]])
            .collect();
        queue.write_texture(
            texture.as_image_copy(),
            bytemuck::cast_slice(&texels),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(p.width * 16),
                rows_per_image: Some(p.height),
            },
            texture.size(),
        );
        self.picture = Some((texture, made));
    }
}

fn size_of(texture: &wgpu::Texture) -> [u32; 2] {
    [texture.width(), texture.height()]
}

fn try_recv(rx: &Mutex<Receiver<Outcome>>) -> Result<Outcome, TryRecvError> {
    rx.lock().unwrap_or_else(|e| e.into_inner()).try_recv()
}
