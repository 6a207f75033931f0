//! Opening the page in the user's browser, where there is one to open it in.

use std::path::Path;
use std::process::{Command, Stdio};

/// Open `page` in the default browser, without waiting for it. `Err` says why not (no
/// display, no opener): the caller prints the page's path instead.
pub fn open_in_browser(page: &Path) -> Result<(), String> {
    let (program, args): (&str, Vec<&std::ffi::OsStr>) = if cfg!(target_os = "macos") {
        ("open", vec![page.as_os_str()])
    } else if cfg!(windows) {
        (
            "cmd",
            vec![
                "/C".as_ref(),
                "start".as_ref(),
                "".as_ref(),
                page.as_os_str(),
            ],
        )
    } else {
        if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
            return Err("no display (DISPLAY and WAYLAND_DISPLAY are unset)".into());
        }
        ("xdg-open", vec![page.as_os_str()])
    };
    Command::new(program)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map(drop)
        .map_err(|e| format!("{program}: {e}"))
}
