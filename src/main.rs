/// mimalloc: see Cargo.toml (glibc's arena locks under cross-thread frees).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    strandfit::cli::main()
}
