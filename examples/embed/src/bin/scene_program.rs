//! The program of a compiled scene, as `mbdc run` writes it (`cli/src/scene_crate.rs`): the
//! scene's generated code — here the double pendulum's, by this crate's `build.rs` — and a
//! `main` that is `mbdc_runtime::app::main`. `tests/signals.rs` runs it and checks what it
//! does on SIGINT and SIGTERM.

fn main() -> std::process::ExitCode {
    mbdc_runtime::app::main::<mbdc_example_embed::double_pendulum_3d::Model>()
}
