//! The `vadscope` binary: the command line over the library (see `cli`).

mod cli;

fn main() -> std::process::ExitCode {
    // Before anything else runs code compiled for extensions the CPU may lack.
    let missing = vadscope::cpu_guard::missing_extensions();
    if !missing.is_empty() {
        eprintln!("error: {}", vadscope::cpu_guard::refusal(&missing));
        return std::process::ExitCode::FAILURE;
    }
    cli::run()
}
