//! `kloub`: serve the viewer (`kloub serve`) or inspect poses headless (`kloub pose`).

fn main() -> std::process::ExitCode {
    kloub_server::cli::run(std::env::args_os())
}
