//! The `postwarp` command line (placeholder; being written).

/// Entry point.
pub fn main() -> std::process::ExitCode {
    std::process::ExitCode::SUCCESS
}
