//! The `safer` binary; everything lives in [`safer::cli`].

fn main() -> std::process::ExitCode {
    safer::cli::main()
}
