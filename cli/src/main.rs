//! The `mbdc` program: everything is in the library (`src/lib.rs`), so that compiled scenes can
//! share the build of the runtime this program was built with.

fn main() -> std::process::ExitCode {
    mbdc::main()
}
