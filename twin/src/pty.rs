//! A pseudo-terminal for `twin live` (POSIX `openpty` through libc).

use std::ffi::CStr;

/// The master side of a pty, non-blocking, raw.
#[derive(Debug)]
pub struct Pty {
    master: libc::c_int,
    slave: libc::c_int,
    /// Path of the slave device to give to a client.
    pub path: String,
}

impl Pty {
    /// Open a raw pty pair.
    pub fn open() -> Result<Self, String> {
        let mut master: libc::c_int = -1;
        let mut slave: libc::c_int = -1;
        // SAFETY: `openpty` writes two descriptors into the provided
        // out-pointers, which point at live locals; the name, termios and
        // winsize arguments are null (allowed: not requested / defaults).
        let rc =
            unsafe { libc::openpty(&mut master, &mut slave, std::ptr::null_mut(), std::ptr::null(), std::ptr::null()) };
        if rc != 0 {
            return Err(format!("openpty: {}", std::io::Error::last_os_error()));
        }
        // SAFETY: `slave` is a valid open descriptor returned above;
        // `ptsname`-like `ttyname` returns a pointer to a static buffer that
        // is copied into an owned String before any other libc call.
        let path = unsafe {
            let p = libc::ttyname(slave);
            if p.is_null() {
                return Err("ttyname failed".into());
            }
            CStr::from_ptr(p).to_string_lossy().into_owned()
        };
        // SAFETY: `termios` is plain data, fully written by `tcgetattr` on a
        // valid descriptor before it is read; `cfmakeraw`/`tcsetattr` only
        // read/write that struct and the descriptor; `fcntl` on a valid
        // descriptor with integer flags.
        unsafe {
            let mut tio: libc::termios = std::mem::zeroed();
            if libc::tcgetattr(slave, &mut tio) == 0 {
                libc::cfmakeraw(&mut tio);
                libc::tcsetattr(slave, libc::TCSANOW, &tio);
            }
            let fl = libc::fcntl(master, libc::F_GETFL);
            libc::fcntl(master, libc::F_SETFL, fl | libc::O_NONBLOCK);
        }
        Ok(Pty { master, slave, path })
    }

    /// Bytes from the client (0 if none).
    pub fn read(&self, buf: &mut [u8]) -> usize {
        // SAFETY: reads at most `buf.len()` bytes into `buf`, which is a
        // valid writable slice; `master` is an open non-blocking descriptor.
        let n = unsafe { libc::read(self.master, buf.as_mut_ptr().cast(), buf.len()) };
        usize::try_from(n).unwrap_or(0)
    }

    /// Bytes to the client (dropped if the client does not read).
    pub fn write(&self, data: &[u8]) {
        if data.is_empty() {
            return;
        }
        // SAFETY: writes `data.len()` bytes from a valid readable slice to
        // an open descriptor.
        let _ = unsafe { libc::write(self.master, data.as_ptr().cast(), data.len()) };
    }
}

impl Drop for Pty {
    fn drop(&mut self) {
        // SAFETY: both descriptors were opened by `open` and are closed once.
        unsafe {
            libc::close(self.master);
            libc::close(self.slave);
        }
    }
}
