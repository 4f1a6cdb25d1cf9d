//! The refiner pass in the viewer: once the view settles (no drag, no playback), the avatar is
//! drawn again off screen at the viewport's size, refined by its refiner (the default one, or
//! GUAVA's for GUAVA-mode avatars; on a worker thread, by ONNX Runtime on the CPU or our WGSL
//! passes on the viewer's device, `RefinerOn`) and drawn over the raw splat image until
//! anything changes.
//! While the user drags or plays the raw splat is shown: the refiner is left out of those frames
//! — unless refining *while interacting* too, when the latest refined frame stays on screen
//! (behind the input by the refiner's time) and the next is made as soon as the worker is free.

use std::sync::mpsc::{Receiver, TryRecvError};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use guava::camera::Camera;
use guava::refine::{Refiner, RefinerOn};
use guava::render::view::{AvatarRef, PoseRef};

use crate::offscreen::OffscreenRenderer;

/// What a refined frame shows: it is current while all of this is unchanged.
#[derive(Clone, PartialEq)]
pub struct RefineKey {
    /// The refiner model's file.
    pub refiner: std::path::PathBuf,
    /// Where it runs.
    pub on: RefinerOn,
    pub avatar: u64,
    pub pose: u64,
    pub camera: Camera,
    pub background: [f32; 3],
    pub outside: bool,
}

/// A refined frame, composited over the background, as 8-bit sRGB.
struct Refined {
    image: egui::ColorImage,
    /// Time to draw, refine and read it back.
    millis: f32,
    /// Where it ran (`Refiner::engine_name`).
    engine: String,
}

pub struct RefinedView {
    /// Whether the refiner runs when the view settles (the user's switch).
    pub enabled: bool,
    /// Whether it also runs while the user drags or plays, showing its latest frame meanwhile.
    pub while_interacting: bool,
    /// Where it runs (the user's choice).
    pub on: RefinerOn,
    refiner: Arc<Mutex<Option<Refiner>>>,
    pending: Option<(RefineKey, Receiver<Result<Refined, String>>)>,
    shown: Option<(RefineKey, egui::TextureHandle)>,
    /// The last refined frame's cost and where it ran, and the last error (shown in the
    /// display panel).
    pub last_ms: Option<(f32, String)>,
    pub error: Option<String>,
    /// Why the avatar on screen has no refiner to run (shown in the display panel).
    pub unavailable: Option<String>,
    /// Refined frames shown so far.
    pub frames: u64,
    /// Whether the frame on screen is the refined one, and whether it is behind the view (an
    /// earlier frame's, while interacting).
    pub showing: bool,
    pub behind: bool,
}

impl Default for RefinedView {
    fn default() -> Self {
        Self {
            enabled: true,
            while_interacting: false,
            on: RefinerOn::Auto,
            refiner: Arc::default(),
            pending: None,
            shown: None,
            last_ms: None,
            error: None,
            unavailable: None,
            frames: 0,
            showing: false,
            behind: false,
        }
    }
}

impl RefinedView {
    /// The refined frame for `key` if it is ready; otherwise starts making it (one at a time) and
    /// returns `None`, so the caller draws the raw splat image meanwhile — or, with `behind`, the
    /// latest refined frame of an earlier key (interacting: the view moves on faster than the
    /// refiner).
    pub fn frame(
        &mut self,
        ctx: &egui::Context,
        key: RefineKey,
        offscreen: &Arc<Mutex<OffscreenRenderer>>,
        avatar: &AvatarRef,
        pose: &PoseRef,
        behind: bool,
    ) -> Option<egui::TextureId> {
        self.behind = false;
        if let Some((k, texture)) = &self.shown
            && *k == key
        {
            return Some(texture.id());
        }
        let latest = |view: &mut Self| {
            view.behind = behind && view.shown.is_some();
            view.shown.as_ref().filter(|_| behind).map(|(_, t)| t.id())
        };
        if let Some((k, rx)) = &self.pending {
            match rx.try_recv() {
                Err(TryRecvError::Empty) => {
                    ctx.request_repaint_after(std::time::Duration::from_millis(50));
                    return latest(self);
                }
                Ok(Ok(refined)) if *k == key || behind => {
                    let texture =
                        ctx.load_texture("refined view", refined.image, Default::default());
                    self.last_ms = Some((refined.millis, refined.engine));
                    self.frames += 1;
                    self.shown = Some((k.clone(), texture));
                    self.pending = None;
                    if *self.shown.as_ref().map(|(k, _)| k).expect("just set") == key {
                        return self.shown.as_ref().map(|(_, t)| t.id());
                    }
                }
                Ok(Err(e)) => {
                    self.error = Some(e);
                    self.enabled = false;
                    self.pending = None;
                    return None;
                }
                // Stale (the view changed while it was made), or the worker is gone.
                _ => self.pending = None,
            }
        }
        let (tx, rx) = std::sync::mpsc::channel();
        let (refiner, offscreen) = (self.refiner.clone(), offscreen.clone());
        let (avatar, pose, job_key, ctx) = (avatar.clone(), pose.clone(), key.clone(), ctx.clone());
        std::thread::spawn(move || {
            let refined = refine(&refiner, &offscreen, &avatar, &pose, &job_key);
            // The receiver is gone if the view moved on: nothing to do then.
            let _ = tx.send(refined);
            ctx.request_repaint();
        });
        self.pending = Some((key, rx));
        latest(self)
    }
}

/// Draws and refines one frame, composited over the key's background.
fn refine(
    refiner: &Mutex<Option<Refiner>>,
    offscreen: &Mutex<OffscreenRenderer>,
    avatar: &AvatarRef,
    pose: &PoseRef,
    key: &RefineKey,
) -> Result<Refined, String> {
    let started = Instant::now();
    let mut refiner = refiner.lock().unwrap_or_else(|e| e.into_inner());
    let refined = offscreen
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .refine_avatar(
            &mut refiner,
            (&key.refiner, key.on),
            avatar,
            pose,
            key.outside,
            &key.camera,
        )?;
    let rgb = refined.over(key.background);
    Ok(Refined {
        image: egui::ColorImage::from_rgb(
            [rgb.width() as usize, rgb.height() as usize],
            rgb.as_raw(),
        ),
        millis: started.elapsed().as_secs_f32() * 1e3,
        engine: refiner
            .as_ref()
            .map_or(String::new(), |r| r.engine_name().to_string()),
    })
}
