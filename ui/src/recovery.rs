//! When the window cannot go on — the GPU device lost (a driver reset, an unplugged GPU; egui's
//! renderer panics on the next frame then) or any other panic on the UI thread — the avatar the
//! user made is written to a recovery file and one clear message says where, instead of a bare
//! backtrace. Worker threads' panics are left to their jobs, which report them.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use guava::avatar::Avatar;

/// The avatar on screen, kept for the panic hook.
static WORK: Mutex<Option<Arc<Avatar>>> = Mutex::new(None);
/// Why the GPU device was lost, once wgpu said so.
static LOST: Mutex<Option<String>> = Mutex::new(None);
/// The window's device, polled by the hook so a loss not yet reported is.
static DEVICE: Mutex<Option<wgpu::Device>> = Mutex::new(None);

/// Registers the avatar on screen as the work to save if the window dies.
pub fn keep(avatar: Arc<Avatar>) {
    *WORK.lock().unwrap_or_else(|e| e.into_inner()) = Some(avatar);
}

/// Watches the window's device: wgpu's device-lost callback records why it was lost.
pub fn watch(device: &wgpu::Device) {
    device.set_device_lost_callback(|reason, message| {
        *LOST.lock().unwrap_or_else(|e| e.into_inner()) = Some(format!("{reason:?}: {message}"));
    });
    *DEVICE.lock().unwrap_or_else(|e| e.into_inner()) = Some(device.clone());
}

/// Why the device was lost, if it was.
fn lost() -> Option<String> {
    LOST.lock().unwrap_or_else(|e| e.into_inner()).clone()
}

/// Where the avatar is written: `$XDG_DATA_HOME/guava-rs` (or `~/.local/share/guava-rs`).
pub fn recovery_file() -> PathBuf {
    let data = std::env::var_os("XDG_DATA_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/share")))
        .unwrap_or_else(std::env::temp_dir);
    data.join("guava-rs").join("recovered.guava")
}

/// Installs the hook: on a panic of the UI thread, save the work, say what happened, exit 3.
pub fn install_panic_hook() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if std::thread::current().name() != Some("main") {
            return default(info);
        }
        // wgpu delivers the loss when the device is polled; egui's renderer may fail first.
        if let Some(device) = DEVICE.try_lock().ok().and_then(|d| d.clone()) {
            let _ = device.poll(wgpu::PollType::Poll);
        }
        let cause = match lost() {
            Some(reason) => format!("the GPU device was lost ({reason})"),
            None => format!("the viewer failed: {info}"),
        };
        eprintln!("guava-viewer: {cause}.");
        let work = WORK.lock().ok().and_then(|w| w.clone());
        if let Some(avatar) = work {
            let path = recovery_file();
            let saved = std::fs::create_dir_all(path.parent().unwrap_or(&path))
                .map_err(|e| e.to_string())
                .and_then(|()| avatar.save(&path).map_err(|e| e.to_string()));
            match saved {
                Ok(()) => eprintln!(
                    "guava-viewer: your avatar was saved to {} (open it when you restart).",
                    path.display()
                ),
                Err(e) => eprintln!("guava-viewer: saving your avatar failed too: {e}"),
            }
        }
        std::process::exit(3);
    }));
}
