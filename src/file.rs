//! Files written whole or not at all: each is written under a temporary
//! name beside its target and renamed into place, so a failed or
//! interrupted write never leaves a half-written file.

use std::path::{Path, PathBuf};

/// Why an output file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// The extension names no supported format.
    #[error("cannot write `{path}`: unsupported {kind} format (use {choices})")]
    Format {
        /// The target path.
        path: String,
        /// What the file holds ("image", "mesh").
        kind: &'static str,
        /// The extensions that are supported.
        choices: &'static str,
    },
    /// The file system refused (the reason is the error's source, so that
    /// error chains print it once).
    #[error("cannot write `{path}`")]
    Io {
        /// The target path.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The encoder failed.
    #[error("cannot encode `{path}`: {message}")]
    Encode {
        /// The target path.
        path: String,
        /// What the encoder said.
        message: String,
    },
}

/// A file being prepared: its temporary file exists from the start, so an
/// unwritable destination is reported before any work is done. Dropped
/// before [`PendingFile::rename`], it removes the temporary file.
#[derive(Debug)]
pub struct PendingFile {
    target: PathBuf,
    temp: PathBuf,
}

impl PendingFile {
    /// Reserves a temporary file next to `target`.
    pub fn create(target: &Path) -> Result<PendingFile, FileError> {
        let name = target.display().to_string();
        let file_name = target.file_name().ok_or_else(|| FileError::Io {
            path: name.clone(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"),
        })?;
        let temp = target.with_file_name(format!(
            ".{}.{}.tmp",
            file_name.to_string_lossy(),
            std::process::id()
        ));
        std::fs::File::create(&temp).map_err(|source| FileError::Io { path: name, source })?;
        Ok(PendingFile {
            target: target.to_path_buf(),
            temp,
        })
    }

    /// The temporary file, to be written.
    pub fn temp(&self) -> &Path {
        &self.temp
    }

    /// The target, as errors name it.
    pub fn name(&self) -> String {
        self.target.display().to_string()
    }

    /// An error of the file's encoder.
    pub fn encode_error(&self, message: impl std::fmt::Display) -> FileError {
        FileError::Encode {
            path: self.name(),
            message: message.to_string(),
        }
    }

    /// An error of the file system.
    pub fn io_error(&self, source: std::io::Error) -> FileError {
        FileError::Io {
            path: self.name(),
            source,
        }
    }

    /// Renames the written temporary file into place.
    pub fn rename(self) -> Result<(), FileError> {
        std::fs::rename(&self.temp, &self.target).map_err(|source| self.io_error(source))
    }
}

impl Drop for PendingFile {
    fn drop(&mut self) {
        // After a successful rename the temporary name is gone; otherwise this
        // removes the reservation (an error or an interrupted write).
        let _ = std::fs::remove_file(&self.temp);
    }
}
