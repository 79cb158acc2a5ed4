//! Ctrl-C during a fit: the first SIGINT asks the sampler to stop after its next step and
//! checkpoint (the run can then be resumed); a second one ends the process at once.

use std::sync::atomic::{AtomicBool, Ordering};

/// Exit status of a run stopped by SIGINT (128 + 2, as shells report it).
pub const EXIT_INTERRUPTED: u8 = 130;

/// Set by the first SIGINT.
pub static INTERRUPTED: AtomicBool = AtomicBool::new(false);

#[cfg(unix)]
extern "C" fn on_sigint(_signal: libc::c_int) {
    // Only async-signal-safe calls here: an atomic swap, write(2) and _exit(2).
    if INTERRUPTED.swap(true, Ordering::SeqCst) {
        let msg = b"\ninterrupted again: quitting now (the last checkpoint stays resumable)\n";
        // SAFETY: write(2) and _exit(2) are async-signal-safe; `msg` outlives the call.
        unsafe {
            libc::write(2, msg.as_ptr().cast(), msg.len());
            libc::_exit(i32::from(EXIT_INTERRUPTED));
        }
    }
    let msg = b"\ninterrupted: stopping after the current step and its checkpoint (Ctrl-C again to quit at once)\n";
    // SAFETY: as above.
    unsafe {
        libc::write(2, msg.as_ptr().cast(), msg.len());
    }
}

/// Routes SIGINT to [`INTERRUPTED`] from now on.
pub fn install() {
    #[cfg(unix)]
    {
        let handler: extern "C" fn(libc::c_int) = on_sigint;
        // SAFETY: the handler only touches an atomic and async-signal-safe calls.
        unsafe {
            libc::signal(libc::SIGINT, handler as libc::sighandler_t);
        }
    }
}

/// The `--resume` command that continues the run `args` (the program and its arguments) was
/// started with: the same arguments without `--overwrite` (which contradicts resuming), with
/// `--resume`, quoted for a POSIX shell.
pub fn resume_command(args: &[String]) -> String {
    let mut out: Vec<String> = args
        .iter()
        .filter(|a| a.as_str() != "--overwrite")
        .map(|a| shell_quote(a))
        .collect();
    if !args.iter().any(|a| a == "--resume") {
        out.push("--resume".to_owned());
    }
    out.join(" ")
}

fn shell_quote(arg: &str) -> String {
    let plain = !arg.is_empty()
        && arg
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=,:+@%".contains(c));
    if plain {
        arg.to_owned()
    } else {
        format!("'{}'", arg.replace('\'', r"'\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| (*s).to_owned()).collect()
    }

    #[test]
    fn resume_command_drops_overwrite_and_adds_resume_once() {
        assert_eq!(
            resume_command(&args(&[
                "slipbayes",
                "demo",
                "--overwrite",
                "--out",
                "my runs/d"
            ])),
            "slipbayes demo --out 'my runs/d' --resume"
        );
        assert_eq!(
            resume_command(&args(&[
                "slipbayes",
                "fit",
                "m.toml",
                "--resume",
                "--out",
                "r"
            ])),
            "slipbayes fit m.toml --resume --out r"
        );
        assert_eq!(shell_quote("it's"), r"'it'\''s'");
    }
}
