//! The viewport: what the view shows, through which camera, at which resolution, handed to the
//! library's view renderer by a paint callback; or, with nothing to show, what to open.

use std::time::Duration;

use guava::view::{CloudRef, Content, Frame, Look, RefineWith};

use crate::app::GuavaApp;
use crate::compare::Shown;
use crate::files::demo_portrait;
use crate::viewing::{CameraMode, View};
use crate::viewport::ViewportCallback;

/// How soon after the last interactive frame a full-resolution one is drawn (scrolling and
/// playback send no event when they stop).
const SETTLE: Duration = Duration::from_millis(150);

impl GuavaApp {
    /// The viewport, and over it the video driving the body, if any.
    pub(crate) fn viewport_ui(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        self.view_ui(ui);
        self.drive_picture_ui(ui, rect);
    }

    fn view_ui(&mut self, ui: &mut egui::Ui) {
        let mut rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        // The photo beside the avatar: the left half shows it, the avatar draws in the right.
        let photo = match (&mut self.doc.avatar, self.viewing.view) {
            (Some(a), View::Avatar) if self.viewing.display_photo_beside => match &mut a.fidelity {
                Some(Ok(f)) => Some(f.photo(ui.ctx())),
                _ => None,
            },
            _ => None,
        };
        if let Some((texture, uv)) = photo {
            let (left, right) = rect.split_left_right_at_fraction(0.5);
            let [r, g, b] = self
                .viewing
                .background
                .map(|c| (c.clamp(0.0, 1.0) * 255.0) as u8);
            ui.painter()
                .rect_filled(left, 0.0, egui::Color32::from_rgb(r, g, b));
            let side = left.width().min(left.height());
            let square = egui::Rect::from_center_size(left.center(), egui::vec2(side, side));
            ui.painter()
                .image(texture, square, uv, egui::Color32::WHITE);
            rect = right;
        }
        let showing = match self.viewing.view {
            View::Gaussians => self.doc.scene.is_some(),
            View::Body => self.doc.body.is_some(),
            View::Avatar => self.doc.avatar.is_some() && self.doc.body.is_some(),
        };
        if !showing {
            self.empty_state_ui(ui, rect);
            return;
        }
        if !self.gpu.ready {
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "No wgpu device: the viewer needs a Vulkan, Metal or DX12 adapter.",
                egui::FontId::proportional(16.0),
                ui.visuals().error_fg_color,
            );
            return;
        }
        let mut moved = false;
        if response.double_clicked() {
            self.viewing.camera_mode = CameraMode::Orbit;
            self.viewing.frame(&mut self.doc);
        } else if self.viewing.orbit.handle(&response, ui) {
            // Dragging or zooming takes the view back to the orbit camera.
            self.viewing.camera_mode = CameraMode::Orbit;
            moved = true;
        }
        let ppp = ui.ctx().pixels_per_point();
        let (w, h) = (
            (rect.width() * ppp).round() as u32,
            (rect.height() * ppp).round() as u32,
        );
        if w == 0 || h == 0 {
            return;
        }
        let look = |channels: usize| {
            let mut background = vec![0.0; channels];
            for (c, v) in background.iter_mut().zip(self.viewing.background) {
                *c = v;
            }
            Look {
                background,
                display: self.viewing.display.clone(),
            }
        };
        let content = match (
            self.viewing.view,
            &self.doc.scene,
            &mut self.doc.body,
            &self.doc.avatar,
        ) {
            (View::Gaussians, Some(scene), ..) => Content::Cloud {
                cloud: CloudRef {
                    id: scene.id,
                    cloud: scene.cloud.clone(),
                },
                look: look(scene.cloud.channels),
            },
            (View::Avatar, _, Some(body), Some(avatar)) => Content::Avatar {
                avatar: avatar.reference(body),
                pose: body.posed(),
                look: look(avatar.avatar.channels),
                outside: avatar.show_outside,
            },
            (View::Body, _, Some(body), _) => Content::Mesh(body.frame(self.viewing.background)),
            _ => return,
        };
        let playing = self.doc.motion.as_ref().is_some_and(|m| m.is_playing())
            || self.drive.as_ref().is_some_and(|d| d.running());
        // Dragging the split's line moves no content: not interaction.
        let splitting = ui.ctx().is_being_dragged(Self::split_id(ui));
        let pressed = ui.ctx().input(|i| i.pointer.any_down()) && !splitting;
        let interacting = moved || pressed || playing;
        self.viewing.interaction.active = interacting && self.viewing.interaction.scale < 1.0;
        if self.viewing.interaction.active {
            ui.ctx().request_repaint_after(SETTLE);
        }
        let camera = self.viewing.camera(&self.doc, w, h);
        let scale = match self.viewing.interaction.active {
            true => self.viewing.interaction.scale,
            false => 1.0,
        };
        let preview = self.viewing.interaction.active;
        let frame = |content, pane| Frame {
            content,
            camera,
            scale,
            preview,
            pane,
            refine: None,
        };
        if let Content::Mesh(_) = content {
            self.paint_frame(ui, rect, rect, frame(content, 0));
            return;
        }
        // The panes: one view, or the two sides of a split.
        let avatar = matches!(content, Content::Avatar { .. });
        let usable = |s: Shown| {
            if avatar || !s.needs_avatar() {
                s
            } else {
                Shown::Raw
            }
        };
        let panes = match self.viewing.views.compare {
            Some(c) => {
                let (left, right) = rect.split_left_right_at_x(egui::lerp(rect.x_range(), c.at));
                vec![(left, usable(c.left)), (right, usable(c.right))]
            }
            None => vec![(
                rect,
                usable(Shown::of_display(
                    &self.viewing.display,
                    self.refined.enabled,
                )),
            )],
        };
        let refine_now = !interacting || self.refined.while_interacting;
        let refine = match panes.iter().any(|(_, s)| *s == Shown::Refined) && refine_now {
            true => self.refine_with(ui.ctx(), &content, interacting),
            false => None,
        };
        if refine.is_none() {
            // No pane asks for the refined picture: none is on screen.
            let mut report = self.report.lock().unwrap_or_else(|e| e.into_inner());
            (report.refine.showing, report.refine.behind) = (false, false);
        }
        for (pane, &(clip, shown)) in panes.iter().enumerate() {
            match shown.display(&self.viewing.display) {
                Some(display) => {
                    let mut content = content.clone();
                    if let Content::Cloud { look, .. } | Content::Avatar { look, .. } = &mut content
                    {
                        look.display = display;
                    }
                    // The refined pane's frame carries the refiner: the view refines its own
                    // splat image and presents the picture once made (the raw splat before).
                    let mut frame = frame(content, pane);
                    if shown == Shown::Refined {
                        frame.refine = refine.clone();
                    }
                    self.paint_frame(ui, rect, clip, frame);
                }
                None if shown == Shown::Mesh => {
                    if let Some(body) = &mut self.doc.body {
                        let mesh = Content::Mesh(body.frame(self.viewing.background));
                        self.paint_frame(ui, rect, clip, frame(mesh, pane));
                    }
                }
                None => self.photo_pane(ui, rect, clip),
            }
        }
        // The mesh over the avatar (not over a mesh pane: the view has one mesh image).
        if let (true, Some(opacity), Some(body)) =
            (avatar, self.viewing.views.mesh_over, &mut self.doc.body)
            && !panes.iter().any(|(_, s)| *s == Shown::Mesh)
        {
            let mut mesh = body.frame(self.viewing.background);
            mesh.style.overlay = Some(opacity);
            self.paint_frame(ui, rect, rect, frame(Content::Mesh(mesh), 0));
        }
        if let [(left, l), (_, r)] = panes[..] {
            self.split_ui(ui, rect, left.right(), [l, r]);
        }
        self.demo_hint(ui, rect);
    }

    /// Hands a frame to the view renderer, drawn over `rect` and seen only inside `clip`.
    fn paint_frame(&self, ui: &egui::Ui, rect: egui::Rect, clip: egui::Rect, frame: Frame) {
        let callback = ViewportCallback {
            frame,
            report: self.report.clone(),
        };
        ui.painter()
            .with_clip_rect(clip)
            .add(egui_wgpu::Callback::new_paint_callback(rect, callback));
    }

    /// The avatar's photo where its own camera sees it (the viewport's centred square, as
    /// [`guava::camera::Camera::guava_in_viewport`] places it), seen inside `clip`.
    fn photo_pane(&mut self, ui: &egui::Ui, rect: egui::Rect, clip: egui::Rect) {
        let painter = ui.painter().with_clip_rect(clip);
        let [r, g, b] = self
            .viewing
            .background
            .map(|c| (c.clamp(0.0, 1.0) * 255.0) as u8);
        painter.rect_filled(rect, 0.0, egui::Color32::from_rgb(r, g, b));
        match self.doc.avatar.as_mut().map(|a| &mut a.fidelity) {
            Some(Some(Ok(f))) => {
                let (texture, uv) = f.photo(ui.ctx());
                let side = rect.width().min(rect.height());
                let square = egui::Rect::from_center_size(rect.center(), egui::vec2(side, side));
                painter.image(texture, square, uv, egui::Color32::WHITE);
            }
            _ => {
                painter.text(
                    clip.center(),
                    egui::Align2::CENTER_CENTER,
                    "no photo: this avatar was not made here",
                    egui::FontId::proportional(14.0),
                    egui::Color32::from_gray(200),
                );
            }
        }
    }

    /// The split between two views: its line, what each side shows, and its handle (drag it).
    fn split_ui(&mut self, ui: &egui::Ui, rect: egui::Rect, x: f32, shown: [Shown; 2]) {
        let painter = ui.painter();
        let light = egui::Color32::from_gray(230);
        painter.vline(x, rect.y_range(), egui::Stroke::new(1.5, light));
        for (s, at, align) in [
            (shown[0], x - 8.0, egui::Align2::RIGHT_TOP),
            (shown[1], x + 8.0, egui::Align2::LEFT_TOP),
        ] {
            let text = match (s, self.report().refine.showing) {
                (Shown::Refined, false) => "refined (raw until it settles)",
                _ => s.name(),
            };
            let at = egui::pos2(at, rect.top() + 8.0);
            painter.text(at, align, text, egui::FontId::proportional(14.0), light);
        }
        let handle = egui::Rect::from_x_y_ranges(x - 5.0..=x + 5.0, rect.y_range());
        let response = ui
            .interact(handle, Self::split_id(ui), egui::Sense::drag())
            .on_hover_cursor(egui::CursorIcon::ResizeHorizontal);
        if let (Some(p), true, Some(c)) = (
            response.interact_pointer_pos(),
            response.dragged(),
            &mut self.viewing.views.compare,
        ) {
            c.at = ((p.x - rect.left()) / rect.width()).clamp(0.0, 1.0);
        }
    }

    fn split_id(ui: &egui::Ui) -> egui::Id {
        ui.make_persistent_id("viewport_split")
    }

    /// On the demo portrait's avatar (the first launch), how to make one's own.
    fn demo_hint(&self, ui: &egui::Ui, rect: egui::Rect) {
        let demo = demo_portrait();
        let showing_demo = self.viewing.view == View::Avatar
            && !self.viewing.display_photo_beside
            && self.doc.avatar.as_ref().is_some_and(|a| {
                demo.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| a.avatar.source == n)
            });
        if showing_demo {
            ui.painter().text(
                rect.center_bottom() - egui::vec2(0.0, 12.0),
                egui::Align2::CENTER_BOTTOM,
                "The demo portrait's default reconstruction. Drop an upper-body photo here to \
                 make your own avatar.",
                egui::FontId::proportional(15.0),
                egui::Color32::from_gray(220),
            );
        }
    }

    /// What the view refines an avatar's frame with (see [`crate::refined`]); `None` where
    /// the refiner does not apply (and the display panel says why).
    fn refine_with(
        &mut self,
        ctx: &egui::Context,
        content: &Content,
        interacting: bool,
    ) -> Option<RefineWith> {
        self.refined.unavailable = None;
        let Content::Avatar { avatar, .. } = content else {
            return None;
        };
        let gpu = self.gpu.context.as_ref()?;
        let networks = self.doc.networks.as_ref().map(|n| n.dir.as_path());
        let refiner = guava::refine::refiner_for(avatar.avatar.kind, networks);
        self.refined.unavailable = refiner
            .as_ref()
            .err()
            .map(|e| format!("{e} (Mode panel > Networks folder…)"));
        let refiner = refiner.ok()?;
        self.refined.with(ctx, gpu, &refiner, interacting)
    }

    fn empty_state_ui(&mut self, ui: &mut egui::Ui, rect: egui::Rect) {
        let mut child = ui.new_child(
            egui::UiBuilder::new()
                .max_rect(rect)
                .layout(egui::Layout::top_down(egui::Align::Center)),
        );
        child.add_space(rect.height() * 0.35);
        child.heading("Nothing loaded");
        child.label("Drop a 3DGS .ply file here, or use File > Open…");
        child.label("(Body templates, .glb, open in the Body mesh view.)");
        child.label(
            "(A photo .png/.jpg reconstructs an avatar: with its tracking .json beside it, or \
             fitted.)",
        );
        child.add_space(8.0);
        if child.button("Open test scene").clicked() {
            self.open_test_scene();
        }
        if child.button("Reconstruct demo portrait").clicked() {
            self.open(demo_portrait());
        }
        if child.button("Reconstruct synthetic photo").clicked() {
            self.reconstruct_synthetic_photo();
        }
    }
}
