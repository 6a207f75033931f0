mbdc_macros::include_model!("tests/ui/no_such_model.mbd");

fn main() {}
