//! The `jeffcott` binary: parses arguments and reports errors; the work is in the library.

use clap::Parser;
use jeffcott::cli::{Cli, dispatch};

/// Turns off Mesa's Vulkan device-select layer (`VkLayer_MESA_device_select`, an
/// implicit layer installed with Mesa's Vulkan drivers, lavapipe included) for this
/// process, unless the user configures it. Why: wgpu enables every WSI instance
/// extension it finds (`VK_KHR_wayland_surface`, `VK_KHR_xcb_surface`), and with those
/// enabled the layer, when wgpu enumerates the adapters, connects to the Wayland and X
/// displays to find the "default" GPU; without a session (ssh, CI, a batch job)
/// libwayland prints "error: XDG_RUNTIME_DIR is invalid or not set in the environment."
/// on stderr, on every successful run. The layer only reorders the adapters for
/// programs that take the first one; jeffcott lists them all and picks its own
/// (`gpu::DeviceRequest`), so it loses nothing. `NODEVICE_SELECT` is the layer's own
/// switch and touches nothing else (unlike faking `XDG_RUNTIME_DIR`, which would change
/// what every Wayland client library in the process does). A user who sets
/// `NODEVICE_SELECT`, `MESA_VK_DEVICE_SELECT` or `DRI_PRIME` keeps the layer as they
/// set it. The variable is set for this process only (jeffcott starts no children).
fn quiet_vulkan_device_select() {
    let user_chose = ["NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT", "DRI_PRIME"]
        .iter()
        .any(|v| std::env::var_os(v).is_some());
    if !user_chose {
        // SAFETY: called first thing in `main`, before any other thread exists (no
        // rayon pool, no wgpu instance yet), so nothing reads the environment
        // concurrently.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

fn main() -> std::process::ExitCode {
    quiet_vulkan_device_select();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => match jeffcott::cli::one_line_usage_error(&e) {
            Some(line) => {
                eprintln!("{line}");
                return std::process::ExitCode::from(2);
            }
            // --help and --version print as clap writes them.
            None => e.exit(),
        },
    };
    let result = dispatch(&cli.command);
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // The error's own text: an I/O error already says the operating system's
            // reason once (a `{:#}` chain would repeat it).
            eprintln!("error: {e}");
            std::process::ExitCode::from(jeffcott::cli::exit_code(&e))
        }
    }
}
