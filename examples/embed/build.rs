//! The build.rs route: generate the double pendulum's Rust into OUT_DIR. Cargo reruns this
//! when the model file (or anything it imports) changes.

fn main() {
    mbdc_compiler::build("../../models/double_pendulum_3d.mbd");
}
