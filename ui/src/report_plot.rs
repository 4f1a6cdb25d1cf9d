//! The last `guava report`'s error-against-time plot in the viewer: its `tradeoffs.csv` read back
//! (the repository's committed run until the user opens another report folder) and drawn as a
//! scatter with time on a log axis and the Pareto front in red, as the report's SVG draws it.

use std::path::{Path, PathBuf};

/// One setting of the sweep.
pub struct Setting {
    pub label: String,
    pub total_ms: f64,
    pub psnr_db: f64,
    pub pareto: bool,
}

pub struct ReportPlot {
    pub folder: PathBuf,
    /// Whose run it is: the repository's committed one or the user's, and the machine its
    /// `report.md` names.
    pub whose: String,
    pub settings: Result<Vec<Setting>, String>,
}

/// The report committed in the repository (`docs/report/`).
pub fn committed_report() -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/report");
    path.canonicalize().unwrap_or(path)
}

impl ReportPlot {
    /// Reads `folder/tradeoffs.csv`; a missing or malformed file is an error naming it.
    pub fn read(folder: &Path) -> Self {
        let path = folder.join("tradeoffs.csv");
        let settings = std::fs::read_to_string(&path)
            .map_err(|e| format!("{}: {e}", path.display()))
            .and_then(|text| parse(&text).map_err(|e| format!("{}: {e}", path.display())));
        let committed = folder.canonicalize().ok() == committed_report().canonicalize().ok();
        let machine = std::fs::read_to_string(folder.join("report.md"))
            .ok()
            .and_then(|md| machine_line(&md));
        let whose = format!(
            "{}{}",
            match committed {
                true =>
                    "the run committed with this version (the CI machine), not yours: run \
                         `guava report --out DIR` and open DIR for your own",
                false => "your run",
            },
            machine.map_or(String::new(), |m| format!(" — {m}"))
        );
        Self {
            folder: folder.to_path_buf(),
            whose,
            settings,
        }
    }

    pub fn ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.label(format!("report: {}", self.folder.display()))
                .on_hover_text(&self.whose);
            if ui.button("Open report…").clicked()
                && let Some(dir) = rfd::FileDialog::new().pick_folder()
            {
                *self = Self::read(&dir);
            }
        });
        ui.label(egui::RichText::new(&self.whose).small());
        match &self.settings {
            Err(e) => {
                ui.colored_label(ui.visuals().error_fg_color, e);
            }
            Ok(settings) => plot(ui, settings),
        }
    }
}

/// The adapter and CPU a report was measured on: its `Machine:` line, up to the first period
/// after the CPU.
fn machine_line(md: &str) -> Option<String> {
    let line = md.lines().find_map(|l| l.strip_prefix("Machine: "))?;
    Some(
        line.split(". ")
            .next()
            .unwrap_or(line)
            .trim_end_matches('.')
            .to_string(),
    )
}

fn parse(text: &str) -> Result<Vec<Setting>, String> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().ok_or("empty")?.split(',').collect();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or(format!("no column {name:?}"))
    };
    let (total, psnr, pareto) = (column("total_ms")?, column("psnr_db")?, column("pareto")?);
    let labels: Vec<usize> = ["uv", "gaussians", "features", "side", "refiner"]
        .iter()
        .filter_map(|n| column(n).ok())
        .collect();
    lines
        .enumerate()
        .map(|(i, line)| {
            let cells: Vec<&str> = line.split(',').collect();
            let number = |c: usize| {
                cells
                    .get(c)
                    .and_then(|v| v.parse::<f64>().ok())
                    .filter(|v| v.is_finite())
                    .ok_or(format!(
                        "row {}: column {} is not a number",
                        i + 2,
                        header[c]
                    ))
            };
            Ok(Setting {
                label: labels
                    .iter()
                    .filter_map(|&c| cells.get(c).copied())
                    .collect::<Vec<_>>()
                    .join(", "),
                total_ms: number(total)?,
                psnr_db: number(psnr)?,
                pareto: cells.get(pareto) == Some(&"yes"),
            })
        })
        .collect()
}

/// PSNR against time per frame (log), hovering a dot names its setting.
fn plot(ui: &mut egui::Ui, settings: &[Setting]) {
    let shown: Vec<&Setting> = settings.iter().filter(|s| s.total_ms > 0.0).collect();
    if shown.is_empty() {
        ui.label("no settings to plot");
        return;
    }
    let (t0, t1) = shown.iter().fold((f64::MAX, f64::MIN), |(a, b), s| {
        (a.min(s.total_ms.log10()), b.max(s.total_ms.log10()))
    });
    let (p0, p1) = shown.iter().fold((f64::MAX, f64::MIN), |(a, b), s| {
        (a.min(s.psnr_db), b.max(s.psnr_db))
    });
    let (t0, t1) = (t0.floor(), t1.ceil().max(t0.floor() + 1.0));
    let (p0, p1) = ((p0 - 1.0).floor(), (p1 + 1.0).ceil());
    let size = egui::vec2(ui.available_width().min(420.0), 200.0);
    let (response, painter) = ui.allocate_painter(size, egui::Sense::hover());
    let area = response.rect.shrink2(egui::vec2(30.0, 16.0));
    let at = |s: &Setting| {
        egui::pos2(
            egui::lerp(
                area.x_range(),
                ((s.total_ms.log10() - t0) / (t1 - t0)) as f32,
            ),
            egui::lerp(area.y_range(), ((p1 - s.psnr_db) / (p1 - p0)) as f32),
        )
    };
    let ink = ui.visuals().text_color();
    painter.rect_stroke(
        area,
        0.0,
        (1.0, ink.gamma_multiply(0.4)),
        egui::StrokeKind::Inside,
    );
    let font = egui::FontId::monospace(10.0);
    for (text, pos, align) in [
        (
            format!("{} ms", 10f64.powf(t0)),
            area.left_bottom(),
            egui::Align2::LEFT_TOP,
        ),
        (
            format!("{} ms", 10f64.powf(t1)),
            area.right_bottom(),
            egui::Align2::RIGHT_TOP,
        ),
        (format!("{p1} dB"), area.left_top(), egui::Align2::RIGHT_TOP),
        (
            format!("{p0} dB"),
            area.left_bottom(),
            egui::Align2::RIGHT_BOTTOM,
        ),
    ] {
        painter.text(pos, align, text, font.clone(), ink);
    }
    let mut front: Vec<&Setting> = shown.iter().copied().filter(|s| s.pareto).collect();
    front.sort_by(|a, b| a.total_ms.total_cmp(&b.total_ms));
    let red = egui::Color32::from_rgb(220, 60, 50);
    painter.add(egui::Shape::line(
        front.iter().map(|s| at(s)).collect(),
        (1.5, red),
    ));
    let hover = response.hover_pos();
    let mut hovered = None;
    for s in &shown {
        let p = at(s);
        let colour = if s.pareto {
            red
        } else {
            ink.gamma_multiply(0.7)
        };
        painter.circle_filled(p, 2.5, colour);
        if hover.is_some_and(|h| h.distance(p) < 5.0) {
            hovered = Some(*s);
        }
    }
    if let Some(s) = hovered {
        response.on_hover_text(format!(
            "{}: {:.1} ms, {:.2} dB",
            s.label, s.total_ms, s.psnr_db
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_committed_report_reads_with_a_pareto_front() {
        let plot = ReportPlot::read(&committed_report());
        // It says whose run it is and on what machine.
        assert!(
            plot.whose.starts_with("the run committed") && plot.whose.contains("llvmpipe"),
            "{}",
            plot.whose
        );
        let settings = plot.settings.expect("docs/report/tradeoffs.csv");
        assert!(settings.len() > 10);
        assert!(settings.iter().any(|s| s.pareto));
        assert!(
            settings
                .iter()
                .all(|s| s.total_ms > 0.0 && s.psnr_db.is_finite())
        );
    }

    #[test]
    fn a_report_of_ones_own_says_so() {
        let dir = std::env::temp_dir().join(format!("guava-report-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        std::fs::write(
            dir.join("tradeoffs.csv"),
            "uv,total_ms,psnr_db,pareto\n448,3.5,22.1,yes\n",
        )
        .expect("csv");
        std::fs::write(
            dir.join("report.md"),
            "# guava report\n\nMachine: NVIDIA H200 · Vulkan · DiscreteGpu; CPU X. Subject: …\n",
        )
        .expect("md");
        let plot = ReportPlot::read(&dir);
        assert_eq!(
            plot.whose,
            "your run — NVIDIA H200 · Vulkan · DiscreteGpu; CPU X"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_malformed_table_is_named() {
        let err = parse("uv,total_ms,psnr_db,pareto\n448,fast,22.1,yes\n")
            .err()
            .expect("refused");
        assert!(err.contains("row 2") && err.contains("total_ms"), "{err}");
    }
}
