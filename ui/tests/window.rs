//! The real window: start `guava-viewer` on a virtual X server (Xvfb), wait until it has drawn,
//! take a screenshot of the X screen with ImageMagick's `import`, check it shows the app, and check
//! the viewer exits cleanly on its own. Needs `xvfb` and `imagemagick` (tools/setup.sh installs them).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

struct Xvfb {
    child: Child,
    display: String,
}

impl Xvfb {
    fn start() -> Self {
        // A display number unlikely to clash with a developer's own or a parallel test run, and
        // one per test: the tests of this file run in parallel in one process (sharing a number,
        // the first to finish took the other's screen away; CI caught it).
        static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let test = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let n = 100 + (std::process::id() % 100) * 4 + test;
        let display = format!(":{n}");
        let child = Command::new("Xvfb")
            .args([
                display.as_str(),
                "-screen",
                "0",
                "1280x800x24",
                "-nolisten",
                "tcp",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb not found: install it with `bash tools/setup.sh` (Debian package xvfb)");
        let lock = PathBuf::from(format!("/tmp/.X{n}-lock"));
        let start = Instant::now();
        while !lock.exists() && start.elapsed() < Duration::from_secs(10) {
            std::thread::sleep(Duration::from_millis(50));
        }
        std::thread::sleep(Duration::from_millis(300));
        Self { child, display }
    }
}

impl Xvfb {
    /// The viewer on this display (stdout and stderr piped), ready for its arguments.
    fn viewer(&self) -> Command {
        let mut viewer = Command::new(env!("CARGO_BIN_EXE_guava-viewer"));
        viewer
            .env("DISPLAY", &self.display)
            .env("XDG_RUNTIME_DIR", runtime_dir())
            .env_remove("WAYLAND_DISPLAY")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        viewer
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn runtime_dir() -> PathBuf {
    let dir = std::env::temp_dir().join("guava-xdg-runtime");
    std::fs::create_dir_all(&dir).expect("runtime dir");
    dir
}

/// Photographs the X screen (ImageMagick's `import`) into `path`.
fn photograph_screen(display: &str, path: &Path) {
    let status = Command::new("import")
        .args(["-display", display, "-window", "root"])
        .arg(path)
        .status()
        .expect("ImageMagick `import` (bash tools/setup.sh installs imagemagick)");
    assert!(status.success(), "import failed");
}

/// Waits (at most 180 s) for the viewer to exit by itself; its status and stderr.
fn wait_for_exit(viewer: &mut Child, what: &str) -> (std::process::ExitStatus, String) {
    let start = Instant::now();
    let exit = loop {
        if let Some(status) = viewer.try_wait().expect("wait") {
            break status;
        }
        assert!(start.elapsed() < Duration::from_secs(180), "{what}");
        std::thread::sleep(Duration::from_millis(100));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut viewer.stderr.take().expect("stderr"), &mut stderr).ok();
    (exit, stderr)
}

/// Fraction of pixels in a region that are far from black, and how many distinct colours it has.
fn region_stats(img: &image::RgbImage, x0: u32, y0: u32, x1: u32, y1: u32) -> (f64, usize) {
    let mut lit = 0u64;
    let mut colours = std::collections::HashSet::new();
    for y in y0..y1 {
        for x in x0..x1 {
            let p = img.get_pixel(x, y).0;
            if p.iter().map(|&c| c as u32).sum::<u32>() > 90 {
                lit += 1;
            }
            colours.insert([p[0] >> 4, p[1] >> 4, p[2] >> 4]);
        }
    }
    (lit as f64 / ((x1 - x0) * (y1 - y0)) as f64, colours.len())
}

#[test]
fn the_viewer_window_shows_the_scene_and_exits_cleanly() {
    let xvfb = Xvfb::start();
    let dir = std::env::temp_dir().join(format!("guava-window-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let self_shot = dir.join("frame.png");
    let x_shot = dir.join("screen.png");
    let mut viewer = xvfb
        .viewer()
        .args(["--test-scene", "--exit-after-secs", "15", "--screenshot"])
        .arg(&self_shot)
        .spawn()
        .expect("guava-viewer starts");
    let stdout = BufReader::new(viewer.stdout.take().expect("stdout"));
    let mut ready = false;
    for line in stdout.lines().map_while(Result::ok) {
        if line.contains("guava-viewer: ready") {
            ready = true;
            break;
        }
    }
    assert!(ready, "the viewer never reported its first frames");
    // Give the splatting pass a few frames, then photograph the X screen itself (the viewer
    // stays up for 15 s from launch, whatever its frame rate).
    std::thread::sleep(Duration::from_secs(2));
    photograph_screen(&xvfb.display, &x_shot);
    let (exit, stderr) = wait_for_exit(&mut viewer, "the viewer did not exit by itself");
    assert!(
        exit.success(),
        "viewer exit status {exit}; stderr:\n{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");

    check_screenshot(&x_shot);
    check_screenshot(&self_shot);
    std::fs::remove_dir_all(&dir).ok();
}

/// The first launch, as a new user sees it: the demo portrait's avatar in the viewport (orange
/// suit, skin) once it is made. Then a GPU device lost mid-session (destroyed by the viewer's
/// fault injection, as a driver reset would): no hang and no bare backtrace; the viewer says so,
/// writes the avatar on screen to its recovery file and exits with status 3.
#[test]
fn the_first_launch_shows_the_avatar_and_a_lost_device_saves_it() {
    let xvfb = Xvfb::start();
    let dir = std::env::temp_dir().join(format!("guava-window-first-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut viewer = xvfb
        .viewer()
        .args(["--lose-device-after", "6"])
        .env("XDG_DATA_HOME", &dir)
        .spawn()
        .expect("guava-viewer starts");
    let stdout = BufReader::new(viewer.stdout.take().expect("stdout"));
    let showing = stdout
        .lines()
        .map_while(Result::ok)
        .find(|l| l.starts_with("guava-viewer: showing"));
    assert_eq!(
        showing.as_deref(),
        Some("guava-viewer: showing demo_portrait.png"),
        "the first launch opens the demo portrait's avatar"
    );
    std::thread::sleep(Duration::from_secs(2));
    let shot = dir.join("first_launch.png");
    photograph_screen(&xvfb.display, &shot);
    let img = image::open(&shot).expect("screenshot").to_rgb8();
    let (w, h) = img.dimensions();
    let (mut suit, mut total) = (0u64, 0u64);
    for y in 100..h - 120 {
        for x in 560..w - 40 {
            let [r, g, b] = img.get_pixel(x, y).0;
            total += 1;
            suit += u64::from(r > 170 && (50..170).contains(&g) && b < 110);
        }
    }
    let share = suit as f64 / total as f64;
    println!("first launch: {share:.3} of the viewport is the suit's orange");
    assert!(
        share > 0.05,
        "the avatar is not in the viewport ({share:.3})"
    );

    let (exit, stderr) = wait_for_exit(&mut viewer, "the viewer hung after losing its device");
    assert_eq!(exit.code(), Some(3), "{stderr}");
    assert!(stderr.contains("the GPU device was lost"), "{stderr}");
    let recovered = dir.join("guava-rs/recovered.guava");
    assert!(
        stderr.contains(&recovered.display().to_string()),
        "{stderr}"
    );
    let saved = guava::avatar::Avatar::load(&recovered).expect("the recovered avatar loads");
    assert_eq!(saved.source, "demo_portrait.png");
    assert!(saved.uv.local.len() > 100_000);
    std::fs::remove_dir_all(&dir).ok();
}

/// The window fills the 1280×800 screen: a UI panel on the left, the splatted scene on the right.
fn check_screenshot(path: &Path) {
    let img = image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8();
    let (w, h) = img.dimensions();
    assert!(w >= 1000 && h >= 700, "{}: {w}×{h}", path.display());
    let (panel_lit, panel_colours) = region_stats(&img, 0, 30, 380, h - 40);
    let (view_lit, view_colours) = region_stats(&img, 600, 150, w - 60, h - 150);
    println!(
        "{}: panel lit {panel_lit:.3} ({panel_colours} colours), viewport lit {view_lit:.3} ({view_colours} colours)",
        path.display()
    );
    assert!(
        panel_lit > 0.01 && panel_colours > 4,
        "{}: the side panel has no UI",
        path.display()
    );
    // The torus knot covers a good part of the viewport in many hues.
    assert!(
        view_lit > 0.1,
        "{}: the viewport is (nearly) black",
        path.display()
    );
    assert!(
        view_colours > 50,
        "{}: the viewport has too few colours to be the scene",
        path.display()
    );
}

#[test]
fn without_a_display_it_says_what_is_missing() {
    let out = Command::new(env!("CARGO_BIN_EXE_guava-viewer"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("guava-viewer runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("no display") && stderr.contains("xvfb-run"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}
