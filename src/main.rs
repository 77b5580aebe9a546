//! The `postwarp` command line: parse arguments and hand over to `cli::run`.

/// Huge pages for the frame planes (`postwarp::huge_pages`).
#[global_allocator]
static ALLOC: postwarp::huge_pages::HugePageAlloc = postwarp::huge_pages::HugePageAlloc;

fn main() -> std::process::ExitCode {
    postwarp::cli::main()
}
