//! `guava-viewer`: the desktop window.

use clap::Parser;
use guava_ui::{GuavaApp, Options};
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Parser)]
#[command(name = "guava-viewer", version, about = "GUAVA avatar viewer")]
struct Args {
    /// Files to open, in order: 3DGS .ply, body template .glb, avatar .guava, a photo (.png/.jpg,
    /// with its tracking .json beside it) to reconstruct, a motion (.json, ARKit .csv, SMPL-X
    /// .npz), or for GUAVA mode an EHM body .npz and GUAVA's networks folder.
    files: Vec<PathBuf>,
    /// Start with the synthetic test scene.
    #[arg(long)]
    test_scene: bool,
    /// Save the window's frame as PNG (with --exit-after-secs).
    #[arg(long, requires = "exit_after_secs")]
    screenshot: Option<PathBuf>,
    /// Close after this many seconds (for tests and scripted screenshots).
    #[arg(long)]
    exit_after_secs: Option<f32>,
    /// Start with the motion paused at this time (seconds) instead of playing.
    #[arg(long)]
    motion_time: Option<f32>,
    /// Fault injection: destroy the GPU device this many seconds after what was asked to open
    /// has opened, as a driver reset would (the viewer saves your avatar and exits with a message).
    #[arg(long, hide = true)]
    lose_device_after: Option<f32>,
    /// Drive the body live from this video (MP4/MOV with H.264, or a folder of frames) once
    /// what is opened has opened (as *Drive > From video…*).
    #[arg(long)]
    drive: Option<PathBuf>,
}

fn main() {
    guava::gpu::quiet_without_wayland();
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let args = Args::parse();
    if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
        eprintln!(
            "guava-viewer: no display (neither DISPLAY nor WAYLAND_DISPLAY is set). Run it on a desktop, \
             or under a virtual X server: `xvfb-run -a guava-viewer` (Debian package `xvfb`)."
        );
        std::process::exit(2);
    }
    let options = Options {
        open: args.files,
        test_scene: args.test_scene,
        screenshot: args.screenshot,
        exit_after_secs: args.exit_after_secs,
        autoplay: true,
        motion_time: args.motion_time,
        lose_device_after: args.lose_device_after,
        demo_avatar: true,
        drive: args.drive,
    };
    guava_ui::recovery::install_panic_hook();
    let mut setup = egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    // The splatting pass needs more than egui's default limits; ask for them on egui's own device.
    setup.device_descriptor = Arc::new(guava::gpu::device_descriptor);
    setup.instance_descriptor.backends =
        wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("guava-rs viewer")
            .with_inner_size([1280.0, 800.0])
            .with_drag_and_drop(true),
        renderer: eframe::Renderer::Wgpu,
        wgpu_options: egui_wgpu::WgpuConfiguration {
            wgpu_setup: egui_wgpu::WgpuSetup::CreateNew(setup),
            ..Default::default()
        },
        ..Default::default()
    };
    let result = eframe::run_native(
        "guava-rs viewer",
        native,
        Box::new(move |cc| Ok(Box::new(GuavaApp::new(cc, options)))),
    );
    if let Err(e) = result {
        eprintln!("guava-viewer: could not open the window: {e}");
        eprintln!(
            "  A Vulkan driver is needed (without a GPU: `apt-get install mesa-vulkan-drivers libvulkan1`), \
             and an X11 display (or `xvfb-run -a`)."
        );
        std::process::exit(1);
    }
}
