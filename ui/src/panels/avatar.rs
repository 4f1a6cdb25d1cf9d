//! The avatar panel: what the avatar is and where it came from, the photo it was made from with
//! the keypoints and the fit over it, and adjusting that fit by hand.

use std::path::Path;

use guava::avatar::AvatarKind;
use guava::body::Posable;
use guava::tracking::SourceView;

use crate::app::GuavaApp;
use crate::avatar_view::FitAction;
use crate::files::file_name;
use crate::viewing::CameraMode;

impl GuavaApp {
    pub(crate) fn avatar_ui(&mut self, ui: &mut egui::Ui) {
        let Some(avatar) = &mut self.doc.avatar else {
            return;
        };
        ui.heading("Avatar");
        ui.label(&avatar.label);
        let a = &avatar.avatar;
        ui.label(format!(
            "{} Gaussians: {} · {} channels ({})",
            a.len(),
            a.composition(),
            a.channels,
            match a.kind {
                AvatarKind::DefaultReconstruction => "RGB, source confidence",
                AvatarKind::Guava => "RGB, then GUAVA's latent features for its refiner",
            }
        ));
        if a.outside > 0 {
            ui.checkbox(
                &mut avatar.show_outside,
                format!(
                    "show the body the photo did not show ({} Gaussians, grey)",
                    a.outside
                ),
            );
        }
        let mut action = None;
        if let (Some(source), Some(body)) = (&mut avatar.source, &mut self.doc.body) {
            egui::CollapsingHeader::new("Source photo and fit")
                .default_open(true)
                .show(ui, |ui| action = source.ui(ui, body));
        }
        match &mut avatar.fidelity {
            Some(Ok(fidelity)) => {
                egui::CollapsingHeader::new("Against its photo")
                    .default_open(true)
                    .show(ui, |ui| fidelity.ui(ui));
            }
            Some(Err(e)) => {
                ui.label(format!("not compared with its photo: {e}"));
            }
            None => {}
        }
        if let Some(photo) = &mut avatar.tracked_photo {
            egui::CollapsingHeader::new("Source photo and tracking")
                .default_open(true)
                .show(ui, |ui| photo.ui(ui));
        }
        ui.separator();
        if let Some(action) = action {
            self.fit_action(action);
        }
    }

    /// Adjusting the source photo's fit by hand: start (the body takes the fit's pose, playback
    /// pauses, the view looks through the photo's camera), stop, reconstruct with the body's
    /// current pose, or save it as a tracking file.
    pub fn fit_action(&mut self, action: FitAction) {
        let (Some(avatar), Some(body)) = (&mut self.doc.avatar, &mut self.doc.body) else {
            return;
        };
        let Some(source) = &mut avatar.source else {
            return;
        };
        let view = SourceView {
            pose: body.effective_pose(),
            camera: source.view.camera,
            crop: source.view.crop,
        };
        match action {
            FitAction::StartEditing => {
                source.set_editing(true, body);
                if let Some(motion) = &mut self.doc.motion {
                    motion.player.playing = false;
                }
                self.viewing.camera_mode = CameraMode::Source;
            }
            FitAction::StopEditing => source.set_editing(false, body),
            FitAction::Reconstruct => {
                let photo = source.photo.clone();
                self.reconstruct_with_pose(photo, view);
            }
            FitAction::SaveTracking => {
                let photo = source.photo.clone();
                let name = file_name(&photo);
                let tracking = view.to_tracking(
                    &*body.model,
                    &format!(
                        "fitted in guava-viewer to {name}, adjusted by hand; {}",
                        body.model.name()
                    ),
                );
                let beside = guava::pipeline::tracking_beside(Path::new(&name));
                let Some(path) = rfd::FileDialog::new()
                    .add_filter("tracking", &["json"])
                    .set_file_name(beside.display().to_string())
                    .save_file()
                else {
                    return;
                };
                match tracking.save(&path) {
                    Ok(()) => self.info(format!("saved the fit as {}", path.display())),
                    Err(e) => self.error(format!("{}: {e}", path.display())),
                }
            }
        }
    }
}
