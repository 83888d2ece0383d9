//! The serial line under a bus: a device (a USB adapter's `/dev/ttyUSB0`, `/dev/ttyACM0`) opened
//! raw at the bus's baud rate, or the controlling side of a pseudo-terminal for the simulated
//! bus; reads wait at most a timeout (`poll`), so a servo that does not answer is seen.

use std::fs::File;
use std::io::{Read, Write};
use std::os::fd::AsFd;
use std::path::Path;
use std::time::{Duration, Instant};

/// Both vendors' arms ship at 1 Mbaud (SO-101's STS3215, OpenManipulator-X's XM430).
pub const BAUD_RATE: u32 = 1_000_000;

/// `fd` raw (no echo, no line editing, 8 data bits, no parity), reads returning what is there.
fn make_raw(fd: impl AsFd, baud: Option<u32>) -> std::io::Result<()> {
    use rustix::termios::{ControlModes, InputModes};
    use rustix::termios::{OptionalActions, SpecialCodeIndex, tcgetattr, tcsetattr};
    let mut termios = tcgetattr(&fd)?;
    termios.make_raw();
    // No modem lines (an adapter without carrier detect would block) and no flow control (a
    // blocked write would hold the line the torque-off needs).
    termios.control_modes |= ControlModes::CLOCAL | ControlModes::CREAD;
    termios.control_modes &= !ControlModes::CRTSCTS;
    termios.input_modes &= !(InputModes::IXON | InputModes::IXOFF);
    termios.special_codes[SpecialCodeIndex::VMIN] = 0;
    termios.special_codes[SpecialCodeIndex::VTIME] = 0;
    if let Some(baud) = baud {
        termios.set_speed(baud)?;
    }
    tcsetattr(&fd, OptionalActions::Now, &termios)?;
    Ok(())
}

/// Waits until `file` has bytes to read or `timeout` passes; whether it has.
pub fn wait_readable(file: &File, timeout: Duration) -> std::io::Result<bool> {
    use rustix::event::{PollFd, PollFlags, Timespec, poll};
    let mut fds = [PollFd::new(file, PollFlags::IN)];
    let timeout = Timespec { tv_sec: timeout.as_secs() as i64, tv_nsec: i64::from(timeout.subsec_nanos()) };
    match poll(&mut fds, Some(&timeout)) {
        Ok(n) => Ok(n > 0),
        Err(rustix::io::Errno::INTR) => Ok(false),
        Err(e) => Err(e.into()),
    }
}

/// A serial line: send bytes, receive what arrives within a time.
#[derive(Debug)]
pub struct SerialLine {
    file: File,
    name: String,
}

impl SerialLine {
    /// Opens the device at `path` raw at `baud`.
    ///
    /// # Errors
    ///
    /// The device cannot be opened or is not a terminal (its message names the path).
    pub fn open(path: &Path, baud: u32) -> anyhow::Result<Self> {
        use anyhow::Context;
        use std::os::unix::fs::OpenOptionsExt;
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            // Non-blocking to open (a line waiting for carrier detect would hang here), then
            // blocking once it is set up (reads wait in `poll`).
            .custom_flags((rustix::fs::OFlags::NOCTTY | rustix::fs::OFlags::NONBLOCK).bits() as i32)
            .open(path)
            .with_context(|| format!("--port {}: cannot open it", path.display()))?;
        make_raw(&file, Some(baud)).with_context(|| {
            format!("--port {}: not a serial line (cannot set it raw at {baud} baud)", path.display())
        })?;
        let flags = rustix::fs::fcntl_getfl(&file)?;
        rustix::fs::fcntl_setfl(&file, flags & !rustix::fs::OFlags::NONBLOCK)?;
        // Anything an earlier program left unread is not a reply to us.
        let _ = rustix::termios::tcflush(&file, rustix::termios::QueueSelector::IFlush);
        Ok(Self { file, name: path.display().to_string() })
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// Another handle on the line (for the signal handler's torque-off).
    ///
    /// # Errors
    ///
    /// The system's `dup` failed.
    pub fn try_clone_file(&self) -> std::io::Result<File> {
        self.file.try_clone()
    }

    /// Writes `bytes` whole.
    ///
    /// # Errors
    ///
    /// The line's write error.
    pub fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.file.write_all(bytes)?;
        self.file.flush()
    }

    /// Appends to `buffer` what arrives until `done(buffer)` or `timeout` has passed since the
    /// call; whether `done` was reached.
    ///
    /// # Errors
    ///
    /// The line's read error.
    pub fn receive_until(
        &mut self,
        buffer: &mut Vec<u8>,
        timeout: Duration,
        done: impl Fn(&[u8]) -> bool,
    ) -> std::io::Result<bool> {
        let deadline = Instant::now() + timeout;
        let mut chunk = [0u8; 512];
        loop {
            if done(buffer) {
                return Ok(true);
            }
            let now = Instant::now();
            if now >= deadline || !wait_readable(&self.file, deadline - now)? {
                return Ok(done(buffer));
            }
            match self.file.read(&mut chunk) {
                Ok(n) => buffer.extend_from_slice(&chunk[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
}

/// A pseudo-terminal for the simulated bus: the controlling side this program keeps, and the
/// path of the device side a driver (ours, or a vendor's SDK through pyserial) opens.
#[derive(Debug)]
pub struct PseudoTerminal {
    pub controller: File,
    /// Held open so that the controlling side never reads end-of-file between clients.
    _device: File,
    pub device_path: String,
}

impl PseudoTerminal {
    /// A new pseudo-terminal, both sides raw.
    ///
    /// # Errors
    ///
    /// The system has no pseudo-terminals to give.
    pub fn open() -> std::io::Result<Self> {
        use rustix::pty::{OpenptFlags, grantpt, openpt, ptsname, unlockpt};
        let controller = openpt(OpenptFlags::RDWR | OpenptFlags::NOCTTY | OpenptFlags::CLOEXEC)?;
        grantpt(&controller)?;
        unlockpt(&controller)?;
        let name = ptsname(&controller, Vec::new())?;
        let device_path = name.to_string_lossy().into_owned();
        let controller = File::from(controller);
        use std::os::unix::fs::OpenOptionsExt;
        let device = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(rustix::fs::OFlags::NOCTTY.bits() as i32)
            .open(&device_path)?;
        make_raw(&device, None)?;
        make_raw(&controller, None)?;
        Ok(Self { controller, _device: device, device_path })
    }
}
