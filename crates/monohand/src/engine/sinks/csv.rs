//! CSV, one row per hand per frame, with a header.

use super::{Output, Sink, SinkError};
use monohand_io::export::CsvWriter;
use monohand_io::IoResult;
use std::path::Path;

/// Writes one CSV row per hand per frame.
pub struct CsvSink(CsvWriter);

impl std::fmt::Debug for CsvSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("CsvSink")
    }
}

impl CsvSink {
    /// Creates (or truncates) a file and writes the header.
    pub fn create(path: &Path) -> IoResult<CsvSink> {
        Ok(CsvSink(CsvWriter::create(path)?))
    }

    /// Writes to standard output.
    pub fn stdout() -> IoResult<CsvSink> {
        Ok(CsvSink(CsvWriter::new(
            Box::new(std::io::stdout()),
            "<stdout>",
        )?))
    }

    /// [`CsvSink::create`], or [`CsvSink::stdout`] for the path `-`.
    pub fn open(path: &Path) -> IoResult<CsvSink> {
        match path.as_os_str() == "-" {
            true => CsvSink::stdout(),
            false => CsvSink::create(path),
        }
    }
}

impl Sink for CsvSink {
    fn write(&mut self, frame: &Output<'_>) -> Result<(), SinkError> {
        Ok(self.0.write_frame(frame.record)?)
    }
}
