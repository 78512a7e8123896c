//! Byte links for the shell: serial ports and in-memory pipes.

use super::rt_queue::{Receiver, RecvTimeoutError, Sender, bounded};
use std::io::{self, ErrorKind, Read, Write};
use std::time::Duration;

/// Bytes per chunk handed from a reader thread to the loop.
pub const CHUNK_BYTES: usize = 64;

/// A piece of received bytes (fixed size, so channels of chunks do not allocate).
#[derive(Debug, Clone, Copy)]
pub struct Chunk {
    len: u8,
    bytes: [u8; CHUNK_BYTES],
}

impl Chunk {
    /// A chunk of `bytes` (at most [`CHUNK_BYTES`]; the rest is cut).
    pub fn new(bytes: &[u8]) -> Self {
        let len = bytes.len().min(CHUNK_BYTES);
        let mut out = [0u8; CHUNK_BYTES];
        out[..len].copy_from_slice(&bytes[..len]);
        Self { len: len as u8, bytes: out }
    }

    /// The bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }
}

/// The receiving side of a byte link.
pub trait ByteRead: Send {
    /// Reads what has arrived; `Ok(0)` when nothing arrived within the link's timeout.
    fn read_bytes(&mut self, buf: &mut [u8]) -> io::Result<usize>;
}

/// The sending side of a byte link.
pub trait ByteWrite: Send {
    /// Writes all of `bytes`.
    fn write_bytes(&mut self, bytes: &[u8]) -> io::Result<()>;
}

#[cfg(unix)]
impl ByteRead for serialport::TTYPort {
    fn read_bytes(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.read(buf) {
            Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::WouldBlock => Ok(0),
            other => other,
        }
    }
}

#[cfg(unix)]
impl ByteWrite for serialport::TTYPort {
    fn write_bytes(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.write_all(bytes)
    }
}

/// Splits an opened serial port into a reader (with a 10 ms read timeout, so reader
/// threads notice a stop request) and a writer.
#[cfg(unix)]
pub fn split_tty(
    mut port: serialport::TTYPort,
) -> serialport::Result<(serialport::TTYPort, serialport::TTYPort)> {
    use serialport::SerialPort;
    port.set_timeout(Duration::from_millis(10))?;
    let reader = port.try_clone_native()?;
    Ok((reader, port))
}

/// Reading end of an in-memory pipe.
#[derive(Debug)]
pub struct PipeReader {
    rx: Receiver<Chunk>,
}

/// Writing end of an in-memory pipe.
#[derive(Debug, Clone)]
pub struct PipeWriter {
    tx: Sender<Chunk>,
}

/// An in-memory byte pipe holding up to `chunks` chunks.
pub fn pipe(chunks: usize) -> (PipeWriter, PipeReader) {
    let (tx, rx) = bounded(chunks);
    (PipeWriter { tx }, PipeReader { rx })
}

impl From<Receiver<Chunk>> for PipeReader {
    /// Reads a channel of chunks whose sending end another thread holds.
    fn from(rx: Receiver<Chunk>) -> Self {
        Self { rx }
    }
}

impl From<Sender<Chunk>> for PipeWriter {
    /// Writes into a channel of chunks whose receiving end another thread holds.
    fn from(tx: Sender<Chunk>) -> Self {
        Self { tx }
    }
}

impl ByteRead for PipeReader {
    fn read_bytes(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.rx.recv_timeout(Duration::from_millis(10)) {
            Ok(chunk) => {
                let n = chunk.bytes().len().min(buf.len());
                buf[..n].copy_from_slice(&chunk.bytes()[..n]);
                Ok(n)
            }
            Err(RecvTimeoutError::Timeout) => Ok(0),
            Err(RecvTimeoutError::Disconnected) => {
                Err(io::Error::new(ErrorKind::BrokenPipe, "pipe closed"))
            }
        }
    }
}

impl ByteWrite for PipeWriter {
    fn write_bytes(&mut self, bytes: &[u8]) -> io::Result<()> {
        for piece in bytes.chunks(CHUNK_BYTES) {
            self.tx
                .send(Chunk::new(piece))
                .map_err(|_| io::Error::new(ErrorKind::BrokenPipe, "pipe closed"))?;
        }
        Ok(())
    }
}
