//! Errors of `model!` and `include_model!` as the user sees them: an inline model's errors
//! at the tokens they concern, a file's errors rendered with their source lines. (The working
//! expansions are built and run by the example crate `examples/embed`.)

#[test]
fn macro_errors() {
    let t = trybuild::TestCases::new();
    t.compile_fail("tests/ui/*.rs");
}
