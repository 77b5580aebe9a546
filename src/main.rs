//! The `postwarp` command line: parse arguments and hand over to `cli::run`.

fn main() -> std::process::ExitCode {
    postwarp::cli::main()
}
