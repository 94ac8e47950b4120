/// mimalloc: see Cargo.toml (glibc's arena locks under cross-thread frees).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::ffi::{c_int, c_long};

extern "C" {
    // The C library that libmimalloc-sys builds and links (its Rust
    // declarations need the crate's `extended` feature).
    fn mi_option_get(option: c_int) -> c_long;
    fn mi_option_set(option: c_int, value: c_long);
}

/// `mi_option_purge_delay` in mimalloc v2's `mi_option_t` (libmimalloc-sys
/// 0.1.49, pinned by Cargo.lock; 15 in v3 too): how long freed memory waits
/// before it is given back, in ms.
const MI_OPTION_PURGE_DELAY: c_int = 15;
/// Its documented default.
const MI_PURGE_DELAY_DEFAULT: c_long = 10;

/// Freed memory is kept for reuse, not given back (unless
/// `MIMALLOC_PURGE_DELAY`, or its old name `MIMALLOC_RESET_DELAY`, says
/// otherwise; mimalloc reads them in any case, they are looked for here
/// as spelled): mimalloc asks for transparent
/// huge pages, and a page given back in 64 KiB pieces is faulted in again
/// as a fresh 2 MiB page that the kernel zeroes (12 % of the samples of
/// compressing 30,000 noisy heart fibres at 0.1 mm). Measured (2 cores,
/// alternated runs, `compress --tolerance 0.1`, session 54): those heart
/// fibres 6,305 → 399 page faults, 1.94 → 1.86 s and 3.60 → 3.51 s of CPU
/// (another 5 runs with the environment variable: 2.09 → 1.89 s); 100,000
/// fornix replicas and 30,000 tracked streamlines the same time; resident
/// memory within 6 MB (the blocks in flight bound what is live).
fn keep_freed_memory() {
    if ["MIMALLOC_PURGE_DELAY", "MIMALLOC_RESET_DELAY"]
        .iter()
        .any(|name| std::env::var_os(name).is_some())
    {
        return;
    }
    // SAFETY: plain calls into the linked allocator's option table, which
    // bounds-checks the index. That the option still holds the purge
    // delay's default is a check of the index, not a proof (two other
    // options default to 10 as well): a later mimalloc that moved the
    // option would only have another of its tunings set to -1.
    unsafe {
        if mi_option_get(MI_OPTION_PURGE_DELAY) == MI_PURGE_DELAY_DEFAULT {
            mi_option_set(MI_OPTION_PURGE_DELAY, -1);
        }
    }
}

fn main() -> std::process::ExitCode {
    keep_freed_memory();
    strandfit::cli::main()
}
