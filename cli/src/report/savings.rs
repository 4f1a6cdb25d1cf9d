//! What leaving work out saves, measured as with/without pairs on the same frame: the parts of
//! the body the photo never showed, the coarse stand-in drawn while the user interacts, the
//! refiner skipped on interactive frames, and the Gaussians culled when the view holds only part
//! of the avatar (a face close-up, a view half off screen) against the whole upper body.

use anyhow::Result;
use guava::avatar::Avatar;
use guava::body::{BodyModel, BodyPose, PosedBody};
use guava::camera::Camera;
use guava::eval::pairs::{self, View};
use guava::onnx::OnnxRuntime;
use guava::refine::{DEFAULT_REFINER, Refiner};
use guava::render::{GpuAvatar, HeadlessRenderer};

use super::{Table, time_ms};

pub fn run(
    renderer: &mut HeadlessRenderer,
    body: &BodyModel,
    avatar: &Avatar,
    quick: bool,
) -> Result<Table> {
    let reps = if quick { 3 } else { 9 };
    let side = if quick { 256 } else { 512 };
    let mut posed = PosedBody::default();
    body.pose(&BodyPose::rest(body), &mut posed)?;
    let front = View {
        yaw: 0.0,
        pitch: 0.0,
        zoom: 1.0,
        time: None,
    };
    let upper_body = pairs::camera(body, &front, side);
    let background = vec![0.0; avatar.channels];
    let mut table = Table {
        header: vec![
            "what is left out",
            "with (ms)",
            "without (ms)",
            "saved (ms)",
            "detail",
        ],
        rows: Vec::new(),
    };
    // Draws `a` through `camera`: (median ms, drawn, culled).
    let mut draw = |a: &Avatar, outside: bool, camera: &Camera| -> Result<(f64, u64, u64)> {
        let mut gpu = GpuAvatar::new(
            &renderer.gpu.device,
            renderer.pipelines.clone(),
            a,
            &body.triangles,
            Some(&body.weld),
        );
        gpu.show_outside(&renderer.gpu.queue, outside);
        renderer.pose_avatar(&mut gpu, &posed)?;
        let stats = renderer.draw(camera, &background);
        let ms = time_ms(reps, || {
            let _ = renderer.pose_avatar(&mut gpu, &posed);
            renderer.draw(camera, &background);
        });
        Ok((ms, stats.visible, stats.culled()))
    };
    let row = |what: &str, with: f64, without: f64, detail: String| {
        vec![
            what.to_string(),
            format!("{with:.1}"),
            format!("{without:.1}"),
            format!("{:.1}", without - with),
            detail,
        ]
    };

    let (left_out, drawn, _) = draw(avatar, false, &upper_body)?;
    let (all, drawn_all, _) = draw(avatar, true, &upper_body)?;
    table.rows.push(row(
        "parts the photo never showed",
        left_out,
        all,
        format!(
            "{} of {} Gaussians left out; in this view {drawn} drawn (left out) and \
             {drawn_all} (shown): the parts lie below the frame",
            avatar.outside,
            avatar.len()
        ),
    ));
    let preview = avatar.preview();
    let (coarse, coarse_drawn, _) = draw(&preview, false, &upper_body)?;
    table.rows.push(row(
        "all Gaussians, while interacting (the coarse stand-in)",
        coarse,
        left_out,
        format!("{coarse_drawn} Gaussians drawn instead of {drawn}"),
    ));
    for (what, camera) in [
        (
            "what a face close-up does not see",
            pairs::camera(
                body,
                &View {
                    zoom: 4.0,
                    pitch: 15.0,
                    ..front
                },
                side,
            ),
        ),
        (
            "what a view half off screen does not see",
            Camera {
                cx: upper_body.cx + 0.5 * side as f32,
                ..upper_body
            },
        ),
        (
            "what a side view does not see",
            pairs::camera(body, &View { yaw: 90.0, ..front }, side),
        ),
    ] {
        // Culling cannot be turned off, so there is no frame without it to compare: the counts,
        // and the frame's time beside the upper body's.
        let (ms, drawn_here, culled) = draw(avatar, false, &camera)?;
        table.rows.push(vec![
            what.to_string(),
            format!("{ms:.1}"),
            String::new(),
            String::new(),
            format!(
                "{culled} culled, {drawn_here} drawn (the upper body: {drawn} in {left_out:.1} ms)"
            ),
        ]);
    }
    // The refiner: the settled frame drawn and refined, against the same frame drawn alone (as
    // on frames drawn while interacting).
    let mut refiner = Refiner::load(OnnxRuntime::load()?, std::path::Path::new(DEFAULT_REFINER))?;
    let mut gpu = GpuAvatar::new(
        &renderer.gpu.device,
        renderer.pipelines.clone(),
        avatar,
        &body.triangles,
        Some(&body.weld),
    );
    let drawn_only = time_ms(reps, || {
        let _ = renderer.render_avatar(&mut gpu, &posed, &upper_body, &background);
    });
    let drawn_and_refined = time_ms(reps, || {
        if let Ok((image, _)) = renderer.render_avatar(&mut gpu, &posed, &upper_body, &background) {
            let _ = refiner.refine(&image);
        }
    });
    table.rows.push(row(
        "the refiner, on frames drawn while interacting",
        drawn_only,
        drawn_and_refined,
        format!(
            "the frame drawn and read back, then refined by ONNX Runtime on the CPU at {side}²; \
             the viewer refines once the view settles"
        ),
    ));
    // Idle frames are not drawn at all, so there is nothing to time here: the viewer's test
    // counts them.
    table.rows.push(vec![
        "frames when nothing changed".into(),
        String::new(),
        String::new(),
        String::new(),
        "not timed: the viewer draws no frame while idle (counted by its ui test \
         `nothing_changes_nothing_renders`)"
            .into(),
    ]);
    Ok(table)
}
