//! The `stencil` command: argument parsing (in `cli/`) and calls into the library, nothing else.

mod alloc;
mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    // Like any Unix filter: when the reader of our output goes away (`| head`), stop quietly.
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to the default at start-up, before any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    alloc::keep_freed_memory();
    let args = cli::parse();
    match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", cli::errors::one_line(&e));
            ExitCode::FAILURE
        }
    }
}
