//! Generates the scenes the benchmarks compare through the `build.rs` API, in both code
//! layouts: the 3-D double pendulum, the four-bar and the 32-link chain; and the 1000-element
//! beam of `benches/models/beam1000.mbd` in its default layout.

use std::fmt::Write as _;
use std::path::PathBuf;

use mbdc_runtime::compiled::Mode;

fn main() {
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR"));
    let mut text = String::new();
    for (file, module) in [
        ("double_pendulum_3d", "double_pendulum_3d"),
        ("four_bar", "four_bar"),
        ("chain", "chain32"),
    ] {
        for (mode, suffix) in [(Mode::Unrolled, "unrolled"), (Mode::Tables, "tables")] {
            let built = mbdc_compiler::Builder::new(format!("../models/{file}.mbd"))
                .module(&format!("{module}_{suffix}"))
                .mode(mode)
                .out_dir(&out)
                .build();
            writeln!(text, "include!({:?});", built.rs.display().to_string()).unwrap();
        }
    }
    // the beam of `mbdc-bench beams`, in the layout it gets by default (tables: 1001 bodies)
    let built = mbdc_compiler::Builder::new("models/beam1000.mbd")
        .module("beam1000")
        .out_dir(&out)
        .build();
    writeln!(text, "include!({:?});", built.rs.display().to_string()).unwrap();
    mbdc_compiler::embed::write_if_changed(&out.join("models.rs"), &text).expect("models.rs");
}
