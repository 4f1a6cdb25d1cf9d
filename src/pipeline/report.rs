//! What making an avatar reports: each stage's time, how the view and the person mask were
//! found, and what the reconstruction saw; as one line for the viewer's avatar label or as lines
//! for the CLI, written once here for both.

use std::time::Duration;

use crate::fit::FitReport;
use crate::keypoints::Keypoint;
use crate::photo::Crop;
use crate::progress::Stage;

/// Where the person mask came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MaskSource {
    /// The photo's alpha channel.
    #[default]
    Alpha,
    /// The selfie model's person segmentation, cut to the pose model's person.
    Segmentation,
    /// The tracked body's silhouette (no alpha and no pose model; default mode).
    Silhouette,
}

impl MaskSource {
    pub fn describe(self) -> &'static str {
        match self {
            MaskSource::Alpha => "the alpha channel",
            MaskSource::Segmentation => "the person segmentation (selfie and pose models)",
            MaskSource::Silhouette => "the tracked body's silhouette",
        }
    }
}

#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Every stage that ran, in order, with its time.
    pub timings: Vec<(Stage, Duration)>,
    pub mask: MaskSource,
    /// The square of the photo the view sees (`None`: the centred square).
    pub crop: Option<Crop>,
    /// The pose model's body keypoints on the source image, when it ran.
    pub keypoints: Vec<Keypoint>,
    /// The model that placed the body points, when the keypoint models ran.
    pub body_points: Option<&'static str>,
    /// How the pose and camera were fitted, when they were.
    pub fit: Option<FitReport>,
    /// How the fitted body's outline was fitted to the person mask, when it was.
    pub silhouette: Option<crate::fit::SilhouetteReport>,
    /// Valid texels of the UV map, and those the source camera saw.
    pub texels: usize,
    pub observed: usize,
    /// Default mode: texels filled from their mirror image.
    pub mirrored: usize,
    pub behind: usize,
    /// Default mode: texels of hands, teeth and eyes the photo does not show, coloured as what it
    /// shows of them or from the face's skin.
    pub unseen_parts: usize,
    /// Default mode: texels of the body below the photo's bottom edge, coloured as the edge shows it.
    pub past_edge: usize,
    /// Default mode: how far hair stands off the head (metres), and the Gaussians of its shell
    /// behind the head.
    pub hair: f32,
    pub hair_shell: usize,
    /// GUAVA mode: UV Gaussians dropped at opacity ≤ 0.001.
    pub pruned: usize,
    /// Default mode: Gaussians made for the person's pixels the body does not cover.
    pub extras: usize,
    /// Default mode: UV Gaussians on parts the photo did not show, left out (grey on request).
    pub left_out: usize,
    /// GUAVA mode: where the networks' weights came from.
    pub networks: Option<String>,
    /// What went other than asked and how it was handled (models that did not load).
    pub notes: Vec<String>,
}

impl Report {
    /// Takes in the reconstruction's own report (its stages after the fit's).
    pub(super) fn add(&mut self, core: crate::reconstruct::Report) {
        self.timings.extend(core.timings);
        self.texels = core.texels;
        self.observed = core.observed;
        self.mirrored = core.mirrored;
        self.behind = core.behind;
        self.unseen_parts = core.unseen_parts;
        self.past_edge = core.past_edge;
        self.hair = core.hair;
        self.hair_shell = core.hair_shell;
        self.pruned = core.pruned;
        self.extras = core.extras;
        self.left_out = core.left_out;
    }

    pub fn total(&self) -> Duration {
        self.timings.iter().map(|(_, d)| *d).sum()
    }

    /// One line for the avatar's label: where the photo was framed, how the view was fitted,
    /// what the reconstruction saw, and the time.
    pub fn summary(&self) -> String {
        let mut parts = Vec::new();
        if let Some(n) = &self.networks {
            parts.push(format!("networks: {n}"));
        }
        if let Some(c) = self.crop.filter(|_| self.fit.is_some()) {
            parts.push(format!(
                "framed around the person ({}² at {}, {} of the photo)",
                c.side, c.left, c.top
            ));
        }
        if let Some(f) = &self.fit {
            parts.push(self.fit_summary(f));
        }
        if let Some(s) = &self.silhouette {
            parts.push(format!(
                "outline to the mask: IoU {:.2} to {:.2}",
                s.iou_before, s.iou_after
            ));
        }
        parts.push(match self.networks {
            Some(_) => format!(
                "{} of {} texels on faces the photo shows, {} Gaussians pruned",
                self.observed, self.texels, self.pruned
            ),
            None => format!(
                "{} of {} texels seen, {} mirrored, {} on the back from the front, {} on unseen \
                 parts of the hands, teeth and eyes, {} below the photo's edge, rest inpainted; {} \
                 Gaussians beyond the body; {} on parts the photo did not show left out",
                self.observed,
                self.texels,
                self.mirrored,
                self.behind,
                self.unseen_parts,
                self.past_edge,
                self.extras,
                self.left_out
            ),
        });
        parts.extend(self.notes.iter().cloned());
        parts.push(format!("{:.0} ms", self.total().as_secs_f64() * 1e3));
        parts.join("; ")
    }

    fn fit_summary(&self, f: &FitReport) -> String {
        let mut s = format!(
            "pose and camera fitted to {} keypoints{} ({:.1} px RMS)",
            f.keypoints_used,
            self.body_points
                .map_or(String::new(), |m| format!(" of {m}")),
            f.rms_px
        );
        match (&f.face, &f.face_skipped) {
            (Some(face), _) => s.push_str(&format!(
                ", expression to {} face points ({:.1} px RMS)",
                face.points_used, face.rms_px
            )),
            (None, Some(why)) => s.push_str(&format!(", face not fitted ({why})")),
            (None, None) => {}
        }
        if let Some(g) = &f.gaze {
            s.push_str(&format!(", gaze to {} irises", g.observed.len()));
        }
        if f.body_from_face.is_some() {
            s.push_str(", head and shoulders only (from the face and the person mask)");
        }
        for side in &f.unseen_arms {
            s.push_str(&format!(", {side} arm unseen (rests along the body)"));
        }
        if f.legs_at_rest {
            s.push_str(", legs at rest (no knee seen)");
        }
        s
    }

    /// The report as the CLI prints it: the fit in detail, what was seen, the mask, every
    /// stage's time and the total.
    pub fn lines(&self) -> Vec<String> {
        let mut lines = self.fit.as_ref().map(fit_lines).unwrap_or_default();
        if let Some(s) = &self.silhouette {
            lines.push(format!(
                "outline to the person mask: IoU {:.3} → {:.3}, outlines {:.1} → {:.1} px apart",
                s.iou_before, s.iou_after, s.before_px, s.after_px
            ));
        }
        lines.push(match self.networks {
            Some(_) => format!(
                "texels: {} valid, {} on faces the photo shows; {} Gaussians pruned",
                self.texels, self.observed, self.pruned
            ),
            None => format!(
                "texels: {} valid, {} seen by the camera, {} filled by symmetry, {} on the back from \
                 the front, {} on unseen parts of the hands, teeth and eyes, {} below the photo's \
                 edge from the edge, the rest inpainted; {} Gaussians for the person's pixels \
                 beyond the body; {} on parts the photo did not show left out",
                self.texels,
                self.observed,
                self.mirrored,
                self.behind,
                self.unseen_parts,
                self.past_edge,
                self.extras,
                self.left_out
            ),
        });
        if self.networks.is_none() {
            lines.push(format!(
                "hair: {:.1} cm off the head around its outline, {} Gaussians behind the head",
                self.hair * 100.0,
                self.hair_shell
            ));
        }
        lines.push(format!("mask from {}", self.mask.describe()));
        lines.extend(self.notes.iter().cloned());
        for (stage, d) in &self.timings {
            lines.push(format!(
                "{:32} {:8.1} ms",
                stage.name(),
                d.as_secs_f64() * 1e3
            ));
        }
        lines.push(format!(
            "{:32} {:8.1} ms",
            "total",
            self.total().as_secs_f64() * 1e3
        ));
        lines
    }
}

/// A fit in detail: the body keypoints, the face, the hands and the gaze, a line each.
pub fn fit_lines(f: &FitReport) -> Vec<String> {
    let mut lines = vec![format!(
        "fitted to {} body keypoints: {:.1} px RMS after {} iterations",
        f.keypoints_used, f.rms_px, f.iterations
    )];
    match (&f.face, &f.face_skipped) {
        (Some(face), _) => lines.push(format!(
            "face: {} face-mesh points, {:.1} px RMS (rest expression: {:.1} px); head {:.2}× the template's",
            face.points_used,
            face.rms_px,
            face.rms_before_px,
            1.0 + face.head_size.unwrap_or(0.0)
        )),
        (None, Some(why)) => lines.push(format!("face not fitted: {why}")),
        (None, None) => {}
    }
    lines.push(match &f.hands {
        Some(h) => format!(
            "hands: {} found, {} points, {:.1} px RMS (rest fingers: {:.1} px)",
            h.hands,
            h.observed.len(),
            h.rms_px,
            h.rms_before_px
        ),
        None => "hands: none found".into(),
    });
    if let Some(why) = &f.body_from_face {
        lines.push(format!(
            "head and shoulders only ({why}): the head's points from the face mesh, the \
             shoulders' from the person mask"
        ));
    }
    if f.legs_at_rest {
        lines.push(
            "legs at rest: no knee seen confidently (the lower body's points steer the torso and \
             are left out of the RMS)"
                .into(),
        );
    }
    if !f.unseen_arms.is_empty() {
        lines.push(format!(
            "unseen, resting along the body: the {} arm",
            f.unseen_arms.join(" and the ")
        ));
    }
    if let Some(g) = &f.gaze {
        let turns: Vec<String> = g
            .turn_rad
            .iter()
            .map(|t| format!("{:.2}", t.to_degrees()))
            .collect();
        lines.push(format!(
            "gaze: {} irises, {:.1} px RMS (eyes ahead: {:.1} px); eyes turned {}°",
            g.observed.len(),
            g.rms_px,
            g.rms_before_px,
            turns.join(" / ")
        ));
    }
    lines
}
