// Paths are relative to CARGO_MANIFEST_DIR, which trybuild sets to its project folder
// `target/tests/trybuild/mbdc-macros`; this one leads back to the model next to this file.
mbdc_macros::include_model!("../../../../macros/tests/ui/bad_model.mbd");

fn main() {}
