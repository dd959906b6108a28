//! Writing so that a failure (a full disk, a file-size limit, a vanished folder) never
//! leaves a damaged file behind.
//!
//! - Record streams (JSON Lines, CSV) append one whole record per write; when a write
//!   fails half-way, the file is cut back to the end of the last whole record, so it
//!   still parses and holds every record before the failure (`RecordSink`).
//! - Whole files (glTF, OpenPose frames) are written to `PATH.tmp` and renamed, so they
//!   are either complete or absent ([`write_file_atomically`]).

use crate::error::{IoError, IoResult};
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

/// An append-only stream of records that is cut back to its last whole record when a
/// write fails.
pub(crate) struct RecordSink {
    out: Box<dyn Write>,
    /// The same file, to cut back after a failed write (none for pipes and stdout).
    file: Option<File>,
    /// Bytes of whole records written.
    committed: u64,
    /// Name used in errors.
    name: String,
}

impl RecordSink {
    /// Creates (or truncates) a file.
    pub(crate) fn create(path: &Path) -> IoResult<RecordSink> {
        let werr = |error| IoError::Write {
            path: path.to_path_buf(),
            error,
        };
        let f = File::create(path).map_err(werr)?;
        let file = f.try_clone().map_err(werr)?;
        Ok(RecordSink {
            out: Box::new(f),
            file: Some(file),
            committed: 0,
            name: crate::error::name_of(path),
        })
    }

    /// Any sink (standard output, a pipe, a buffer): no cutting back is possible.
    pub(crate) fn new(out: Box<dyn Write>, name: &str) -> RecordSink {
        RecordSink {
            out,
            file: None,
            committed: 0,
            name: name.to_string(),
        }
    }

    /// The name used in errors.
    pub(crate) fn name(&self) -> &str {
        &self.name
    }

    /// Appends one whole record (one or more lines) and flushes it. On failure the file
    /// is cut back to the end of the previous record and the error says so.
    pub(crate) fn append(&mut self, record: &[u8]) -> IoResult<()> {
        let result = self.out.write_all(record).and_then(|()| self.out.flush());
        match result {
            Ok(()) => {
                self.committed += record.len() as u64;
                Ok(())
            }
            Err(error) => {
                let kept = match &self.file {
                    Some(f) => f.set_len(self.committed).is_ok(),
                    None => false,
                };
                let error = if kept {
                    std::io::Error::new(
                        error.kind(),
                        format!(
                            "{error} (the file was cut back to its last whole record, {} bytes)",
                            self.committed
                        ),
                    )
                } else {
                    error
                };
                Err(IoError::Write {
                    path: PathBuf::from(&self.name),
                    error,
                })
            }
        }
    }
}

/// Writes a whole file to `PATH.tmp` and renames it to `PATH`: the file is either complete
/// or absent (a failed write removes the temporary file).
pub fn write_file_atomically(path: &Path, bytes: &[u8]) -> IoResult<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    let written = std::fs::write(&tmp, bytes).map_err(|error| IoError::Write {
        path: tmp.clone(),
        error,
    });
    let result = written.and_then(|()| {
        std::fs::rename(&tmp, path).map_err(|error| IoError::Write {
            path: path.to_path_buf(),
            error,
        })
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A writer that accepts `room` bytes and then fails like a full disk, writing the
    /// part of a buffer that still fits first.
    struct Full {
        file: File,
        room: usize,
    }

    impl Write for Full {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            if self.room == 0 {
                return Err(std::io::Error::other("No space left on device"));
            }
            let n = buf.len().min(self.room);
            self.room -= n;
            self.file.write(&buf[..n])
        }
        fn flush(&mut self) -> std::io::Result<()> {
            self.file.flush()
        }
    }

    #[test]
    fn a_failed_append_cuts_the_file_back_to_whole_records() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.jsonl");
        let file = File::create(&path).unwrap();
        let mut sink = RecordSink {
            out: Box::new(Full {
                file: file.try_clone().unwrap(),
                room: 25,
            }),
            file: Some(file),
            committed: 0,
            name: "r.jsonl".into(),
        };
        sink.append(b"{\"frame\":0}\n").unwrap();
        let e = sink.append(b"{\"frame\":1,\"long\":true}\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("cut back to its last whole record, 12 bytes"),
            "{e}"
        );
        assert_eq!(std::fs::read(&path).unwrap(), b"{\"frame\":0}\n");
    }

    #[test]
    fn atomic_files_are_complete_or_absent() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.glb");
        write_file_atomically(&path, b"glTF").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"glTF");
        // A folder that does not exist: an error, and no temporary file anywhere.
        let bad = dir.path().join("missing").join("b.glb");
        let e = write_file_atomically(&bad, b"glTF").unwrap_err();
        assert!(e.to_string().contains("b.glb.tmp"), "{e}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
