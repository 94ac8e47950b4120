fn main() -> std::process::ExitCode {
    strandfit::cli::main()
}
