//! The host line on a Unix socket, behaving like a serial line with a plug: the executor
//! listens on a path; one host at a time is connected (`mesopush flash`, `run`, `rig`), and
//! when it hangs up the line waits for the next. A host that connects while another is
//! connected takes the line over, as re-plugging the cable would: that is how `mesopush rig
//! stop` reaches an executor at once while `mesopush run` holds the line (the old host sees
//! the line close). Bytes written while nobody is connected are lost, as on an unplugged
//! cable (the reliable link above resynchronises with the next host's session).

use super::port::{ByteRead, ByteWrite};
use std::format;
use std::io::{self, ErrorKind, Read, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::string::{String, ToString};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Read timeout of the connected stream (the reader thread checks for a stop this often).
const READ_TIMEOUT: Duration = Duration::from_millis(10);

type Current = Arc<Mutex<Option<UnixStream>>>;

/// Reading side: accepts connections and reads from the current one.
#[derive(Debug)]
pub struct UnixLineReader {
    listener: UnixListener,
    current: Current,
    reading: Option<UnixStream>,
}

/// Writing side: writes to the current connection, if any.
#[derive(Debug, Clone)]
pub struct UnixLineWriter {
    current: Current,
}

/// Listens on `path` (a stale socket file left by a killed executor is replaced; any other
/// existing file is an error).
pub fn listen(path: &Path) -> io::Result<(UnixLineReader, UnixLineWriter)> {
    remove_stale_socket(path)?;
    let listener = UnixListener::bind(path)
        .map_err(|e| io::Error::new(e.kind(), format!("binding {}: {e}", path.display())))?;
    listener.set_nonblocking(true)?;
    let current: Current = Arc::new(Mutex::new(None));
    let reader = UnixLineReader { listener, current: current.clone(), reading: None };
    Ok((reader, UnixLineWriter { current }))
}

/// Removes `path` if it is a socket nobody listens on; refuses to touch anything else.
pub fn remove_stale_socket(path: &Path) -> io::Result<()> {
    use std::os::unix::fs::FileTypeExt;
    let Ok(meta) = std::fs::symlink_metadata(path) else { return Ok(()) };
    if !meta.file_type().is_socket() {
        let msg = format!("{} exists and is not a socket; refusing to replace it", path.display());
        return Err(io::Error::new(ErrorKind::AlreadyExists, msg));
    }
    if UnixStream::connect(path).is_ok() {
        let msg = format!("{} is in use by another process", path.display());
        return Err(io::Error::new(ErrorKind::AddrInUse, msg));
    }
    std::fs::remove_file(path)
}

impl UnixLineReader {
    fn accept(&mut self) -> io::Result<()> {
        match self.listener.accept() {
            Ok((stream, _)) => {
                stream.set_nonblocking(false)?;
                stream.set_read_timeout(Some(READ_TIMEOUT))?;
                *self.current.lock().map_err(|_| io::Error::other("line lock poisoned"))? =
                    Some(stream.try_clone()?);
                self.reading = Some(stream);
                Ok(())
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                std::thread::sleep(READ_TIMEOUT);
                Ok(())
            }
            Err(e) => Err(e),
        }
    }

    /// A host waiting to connect replaces the current one (whose stream is shut down).
    fn take_over(&mut self) -> io::Result<()> {
        match self.listener.accept() {
            Ok((stream, _)) => {
                if let Some(old) = self.reading.take() {
                    let _ = old.shutdown(std::net::Shutdown::Both);
                }
                stream.set_nonblocking(false)?;
                stream.set_read_timeout(Some(READ_TIMEOUT))?;
                *self.current.lock().map_err(|_| io::Error::other("line lock poisoned"))? =
                    Some(stream.try_clone()?);
                self.reading = Some(stream);
                Ok(())
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => Ok(()),
            Err(e) => Err(e),
        }
    }

    fn hang_up(&mut self) {
        self.reading = None;
        if let Ok(mut c) = self.current.lock() {
            *c = None;
        }
    }
}

impl ByteRead for UnixLineReader {
    fn read_bytes(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.reading.is_some() {
            self.take_over()?;
        }
        let Some(stream) = self.reading.as_mut() else {
            self.accept()?;
            return Ok(0);
        };
        match stream.read(buf) {
            Ok(0) => {
                self.hang_up();
                Ok(0)
            }
            Ok(n) => Ok(n),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => Ok(0),
            Err(e) if e.kind() == ErrorKind::Interrupted => Ok(0),
            Err(_) => {
                self.hang_up();
                Ok(0)
            }
        }
    }
}

impl ByteWrite for UnixLineWriter {
    fn write_bytes(&mut self, bytes: &[u8]) -> io::Result<()> {
        let mut current =
            self.current.lock().map_err(|_| io::Error::other("line lock poisoned"))?;
        if let Some(stream) = current.as_mut()
            && stream.write_all(bytes).is_err()
        {
            *current = None; // the host hung up; the reader notices too
        }
        Ok(())
    }
}

/// Where a line is: a serial device path or `unix:PATH`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LineAddr {
    /// A serial device or pseudo-terminal.
    Serial(String),
    /// A Unix socket path.
    Unix(PathBuf),
}

impl LineAddr {
    /// Parses `unix:PATH` or a device path.
    pub fn parse(text: &str) -> Self {
        match text.strip_prefix("unix:") {
            Some(p) => Self::Unix(PathBuf::from(p)),
            None => Self::Serial(text.to_string()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    #[test]
    fn hosts_connect_one_after_another() {
        let dir = tempdir();
        let path = dir.join("host.sock");
        let (mut r, mut w) = listen(&path).unwrap();
        w.write_bytes(b"lost").unwrap(); // nobody connected
        for round in 0..2u8 {
            let mut host = UnixStream::connect(&path).unwrap();
            host.write_all(&[round, 1, 2]).unwrap();
            let mut got = Vec::new();
            let mut buf = [0u8; 16];
            for _ in 0..500 {
                let n = r.read_bytes(&mut buf).unwrap();
                got.extend_from_slice(&buf[..n]);
                if got.len() >= 3 {
                    break;
                }
            }
            assert_eq!(got, [round, 1, 2]);
            w.write_bytes(b"ok").unwrap();
            let mut back = [0u8; 2];
            host.read_exact(&mut back).unwrap();
            assert_eq!(&back, b"ok");
        }
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_new_host_takes_the_line_over() {
        let dir = tempdir();
        let path = dir.join("host.sock");
        let (mut r, mut w) = listen(&path).unwrap();
        let mut first = UnixStream::connect(&path).unwrap();
        first.write_all(b"a").unwrap();
        let mut buf = [0u8; 16];
        let mut got = Vec::new();
        for _ in 0..500 {
            let n = r.read_bytes(&mut buf).unwrap();
            got.extend_from_slice(&buf[..n]);
            if !got.is_empty() {
                break;
            }
        }
        assert_eq!(got, b"a");
        let mut second = UnixStream::connect(&path).unwrap();
        second.write_all(b"b").unwrap();
        got.clear();
        for _ in 0..500 {
            let n = r.read_bytes(&mut buf).unwrap();
            got.extend_from_slice(&buf[..n]);
            if !got.is_empty() {
                break;
            }
        }
        assert_eq!(got, b"b", "the second host is heard");
        w.write_bytes(b"k").unwrap();
        let mut back = [0u8; 1];
        second.read_exact(&mut back).unwrap();
        assert_eq!(&back, b"k");
        assert_eq!(first.read(&mut back).unwrap(), 0, "the first host's line closed");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_regular_file_is_never_replaced() {
        let dir = tempdir();
        let path = dir.join("plan.bin");
        std::fs::write(&path, b"keep").unwrap();
        assert!(listen(&path).is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"keep");
        std::fs::remove_dir_all(dir).unwrap();
    }

    fn tempdir() -> PathBuf {
        static N: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let d = std::env::temp_dir().join(format!("mp-unix-line-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }
}
