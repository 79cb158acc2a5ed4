use std::process::ExitCode;

fn main() -> ExitCode {
    one_malloc_arena();
    slipbayes_cli::main()
}

/// glibc gives each thread that allocates an arena of its own and keeps what is freed in it:
/// a fit's peak memory then grew with the chain's length through arenas the worker threads
/// had filled and left (one contact: 36.7 MB at 1,000 steps, 45.3 MB at 16,000). With one arena
/// the freed blocks are reused by whichever thread allocates next (29.8 and 32.7 MB), and the
/// demo runs as fast (17.0–17.8 s against 16.7–17.3 s, measured side by side): the samplers'
/// threads evaluate the density in preallocated buffers and hardly allocate. Called before any
/// thread starts, as mallopt requires.
fn one_malloc_arena() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets an allocator parameter; no other thread exists yet.
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, 1);
    }
}
