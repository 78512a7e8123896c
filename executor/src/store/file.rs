//! The std plan store: one file, replaced atomically.
//!
//! Save writes `<path>.tmp`, fsyncs it, renames it over `<path>` and fsyncs the directory,
//! so after a crash or a failed write the file holds either the old plan or the new one,
//! whole. A leftover `.tmp` from an interrupted save is ignored by `load` and overwritten by
//! the next save.

use super::{PlanStore, STORED_HEADER_LEN, decode_header, encode_header};
use crate::error::StoreError;
use crate::shell::fsx::{tmp_path, write_atomic_with};
use mesopush_protocol::flash::FlashHeader;
use std::fs::File;
use std::io::{ErrorKind, Read, Write};
use std::path::{Path, PathBuf};

/// A plan stored in one file.
#[derive(Debug, Clone)]
pub struct FileStore {
    path: PathBuf,
}

impl FileStore {
    /// A store at `path` (created on the first save).
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self { path: path.into() }
    }

    /// The file holding the plan.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The temporary file a save writes first.
    pub fn tmp_path(&self) -> PathBuf {
        tmp_path(&self.path)
    }

    fn write_atomically(&self, header: &FlashHeader, image: &[u8]) -> std::io::Result<()> {
        write_atomic_with(&self.path, |file| {
            file.write_all(&encode_header(header))?;
            file.write_all(image)
        })
    }
}

impl PlanStore for FileStore {
    fn save(&mut self, header: &FlashHeader, image: &[u8]) -> Result<(), StoreError> {
        self.write_atomically(header, image).map_err(|_| StoreError::WriteFailed)
    }

    fn load(&mut self, image: &mut [u8]) -> Result<Option<(FlashHeader, usize)>, StoreError> {
        let mut file = match File::open(&self.path) {
            Ok(file) => file,
            Err(e) if e.kind() == ErrorKind::NotFound => return Ok(None),
            Err(_) => return Err(StoreError::ReadFailed),
        };
        let mut head = [0u8; STORED_HEADER_LEN];
        file.read_exact(&mut head).map_err(|_| StoreError::Corrupt)?;
        let header = decode_header(&head);
        let len = header.image_len_bytes as usize;
        let dst = image.get_mut(..len).ok_or(StoreError::TooLarge)?;
        file.read_exact(dst).map_err(|_| StoreError::Corrupt)?;
        let mut rest = [0u8; 1];
        if file.read(&mut rest).map_err(|_| StoreError::ReadFailed)? != 0 {
            return Err(StoreError::Corrupt);
        }
        header.verify_image(dst).map_err(|_| StoreError::Corrupt)?;
        Ok(Some((header, len)))
    }
}
