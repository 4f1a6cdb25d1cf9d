//! The mode panel: the default reconstruction or GUAVA mode, and the files GUAVA mode and
//! EHM-Tracker's keypoint models need.

use crate::app::GuavaApp;

impl GuavaApp {
    /// Which reconstruction a dropped photo gets, and the files GUAVA mode needs.
    pub(crate) fn mode_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Mode");
        let ehm = self.doc.body.as_ref().is_some_and(|b| b.model.is_ehm());
        ui.label(match (ehm, &self.doc.networks) {
            (false, _) => {
                "Default mode: photos become the default reconstruction on a body template (no \
                 learned weights). GUAVA mode needs an EHM body and GUAVA's networks."
            }
            (true, None) => {
                "GUAVA mode: EHM body open; open GUAVA's networks folder to reconstruct photos."
            }
            (true, Some(_)) => {
                "GUAVA mode: photos are reconstructed by GUAVA's networks on the EHM body, with \
                 their tracking (.json beside them) or fitted to their keypoints."
            }
        });
        if let Some(n) = &self.doc.networks {
            ui.label(&n.label);
        }
        ui.label(match &self.doc.dwpose {
            Some(dir) => format!(
                "Keypoints: body and hands from EHM-Tracker's DWPose ({}); face, irises and mask \
                 from MediaPipe's models",
                dir.display()
            ),
            None => "Keypoints: MediaPipe's models (shipped)".into(),
        });
        let mut pick = None;
        ui.horizontal(|ui| {
            if ui
                .button("EHM body…")
                .on_hover_text("an EHM body converted by tools/convert_ehm.py (.npz)")
                .clicked()
            {
                pick = rfd::FileDialog::new()
                    .add_filter("EHM body", &["npz"])
                    .pick_file();
            }
            if ui
                .button("Networks folder…")
                .on_hover_text("GUAVA's networks exported by tools/export_guava_onnx.py")
                .clicked()
            {
                pick = rfd::FileDialog::new().pick_folder();
            }
            if ehm && ui.button("Default body").clicked() {
                self.load_default_body();
            }
        });
        ui.horizontal(|ui| {
            if ui
                .button("EHM-Tracker's keypoint models…")
                .on_hover_text(
                    "EHM-Tracker's checkpoint folder with yolox_l.onnx and dw-ll_ucoco_384.onnx",
                )
                .clicked()
                && let Some(dir) = rfd::FileDialog::new().pick_folder()
            {
                self.start(Ok(crate::files::wholebody(dir, &self.doc)));
            }
            if self.doc.dwpose.is_some() && ui.button("MediaPipe's keypoints").clicked() {
                self.doc.dwpose = None;
            }
        });
        if let Some(path) = pick {
            self.open(path);
        }
    }
}
