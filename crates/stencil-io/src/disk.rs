//! What stencil finds on disk, worded once: the hidden names its own temporary files and folders
//! take, what a path is when it is not a regular file, and an I/O error in the system's words.

/// Temp files and set-aside old files start with this (hidden, and never an output's name).
pub(crate) const TEMP_PREFIX: &str = ".stencil-";
/// The hidden folder a swap works in.
pub(crate) const SWAP_DIR: &str = ".stencil-swap";

/// What a path is when it is not a regular file, for a message.
pub(crate) fn not_a_file(ft: &std::fs::FileType) -> Option<&'static str> {
    if ft.is_file() {
        return None;
    }
    if ft.is_dir() {
        return Some("a folder");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_fifo() {
            return Some("a named pipe (FIFO)");
        }
        if ft.is_socket() {
            return Some("a socket");
        }
        if ft.is_char_device() || ft.is_block_device() {
            return Some("a device");
        }
    }
    if ft.is_symlink() {
        return Some("a symbolic link");
    }
    Some("not a regular file")
}

/// An I/O error as the operating system words it, once: the OS error alone (without the context
/// some libraries wrap around it, such as tempfile's temp file name), or the error as it was when
/// it carries no OS code and names no temp file.
pub fn plain_io(e: std::io::Error) -> std::io::Error {
    if let Some(code) = e.raw_os_error() {
        return std::io::Error::from_raw_os_error(code);
    }
    let Some(inner) = e.get_ref() else {
        return e;
    };
    let mut cause: Option<&(dyn std::error::Error + 'static)> = Some(inner);
    while let Some(c) = cause {
        if let Some(code) = c
            .downcast_ref::<std::io::Error>()
            .and_then(std::io::Error::raw_os_error)
        {
            return std::io::Error::from_raw_os_error(code);
        }
        cause = c.source();
    }
    if inner.to_string().contains(TEMP_PREFIX) {
        std::io::Error::from(e.kind())
    } else {
        e
    }
}
