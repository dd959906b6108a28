//! CSV: one row per hand per frame, flushed per frame, for spreadsheets and pandas.

use crate::error::IoResult;
use crate::jsonl::FrameRecord;
use crate::sink::RecordSink;
use monohand_core::hand_model::{JOINT_NAMES, NUM_JOINTS};
use std::io::Write;
use std::path::Path;

/// The CSV header: `frame,source,id,side,score,reprojection_error_px`, then for
/// each joint of [`JOINT_NAMES`] `{name}_u,{name}_v,{name}_conf,{name}_x_mm,{name}_y_mm,{name}_z_mm`.
pub fn csv_header() -> String {
    let mut cols: Vec<String> = [
        "frame",
        "source",
        "id",
        "side",
        "score",
        "reprojection_error_px",
    ]
    .map(String::from)
    .to_vec();
    for n in JOINT_NAMES {
        for s in ["u", "v", "conf", "x_mm", "y_mm", "z_mm"] {
            cols.push(format!("{n}_{s}"));
        }
    }
    cols.join(",")
}

/// A CSV field: quoted (RFC 4180) if it contains a comma, quote or line break.
fn csv_text(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// A number as the shortest text that reads back to the same `f64`; empty if not finite.
fn csv_num(v: f64) -> String {
    if v == 0.0 {
        "0".to_string() // not "-0"
    } else if v.is_finite() {
        format!("{v}")
    } else {
        String::new()
    }
}

/// The CSV rows (without line ends) of one frame: one per hand, none if the
/// frame has no hands. Absent values (no id, no 3D, ...) are empty fields.
pub fn csv_rows(frame: &FrameRecord) -> Vec<String> {
    frame
        .hands
        .iter()
        .map(|h| {
            let mut f: Vec<String> = vec![
                frame.frame.to_string(),
                frame.source.as_deref().map(csv_text).unwrap_or_default(),
                h.id.map(|i| i.to_string()).unwrap_or_default(),
                h.side.to_string(),
                h.score.map(csv_num).unwrap_or_default(),
                h.reprojection_error_px.map(csv_num).unwrap_or_default(),
            ];
            for j in 0..NUM_JOINTS {
                f.extend(h.keypoints_2d[j].map(csv_num));
                match h.joints_3d_mm {
                    Some(x) => f.extend(x[j].map(csv_num)),
                    None => f.extend([String::new(), String::new(), String::new()]),
                }
            }
            f.join(",")
        })
        .collect()
}

/// Writes frames as CSV ([`csv_header`], then [`csv_rows`]), flushing after
/// every frame so an interrupted run leaves complete rows.
///
/// A file is cut back to its last whole frame when a write fails (a full disk).
pub struct CsvWriter {
    out: RecordSink,
    rows: usize,
}

impl std::fmt::Debug for CsvWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CsvWriter")
            .field("name", &self.out.name())
            .field("rows", &self.rows)
            .finish()
    }
}

impl CsvWriter {
    /// Creates (or truncates) a file and writes the header.
    pub fn create(path: impl AsRef<Path>) -> IoResult<CsvWriter> {
        CsvWriter::start(RecordSink::create(path.as_ref())?)
    }

    /// Writes to any sink (header first); `name` is used in errors.
    pub fn new(sink: Box<dyn Write>, name: &str) -> IoResult<CsvWriter> {
        CsvWriter::start(RecordSink::new(sink, name))
    }

    fn start(out: RecordSink) -> IoResult<CsvWriter> {
        let mut w = CsvWriter { out, rows: 0 };
        w.out.append(format!("{}\n", csv_header()).as_bytes())?;
        Ok(w)
    }

    /// Writes the rows of one frame (all or none of them) and flushes.
    pub fn write_frame(&mut self, frame: &FrameRecord) -> IoResult<()> {
        let rows = csv_rows(frame);
        let mut text = String::new();
        for row in &rows {
            text.push_str(row);
            text.push('\n');
        }
        self.out.append(text.as_bytes())?;
        self.rows += rows.len();
        Ok(())
    }

    /// Data rows written (not counting the header).
    pub fn rows_written(&self) -> usize {
        self.rows
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::test_support::hand;
    use monohand_core::hand_model::HandSide;

    #[test]
    fn csv_header_and_rows() {
        let header = csv_header();
        let cols: Vec<&str> = header.split(',').collect();
        assert_eq!(cols.len(), 6 + 6 * NUM_JOINTS);
        assert_eq!(cols[6], "wrist_u");
        assert_eq!(cols[11], "wrist_z_mm");
        assert_eq!(cols.last(), Some(&"little_tip_z_mm"));
        let mut two_d = hand(HandSide::Left, None, 400.0);
        two_d.joints_3d_mm = None;
        two_d.score = None;
        let frame = FrameRecord {
            frame: 7,
            source: Some("a,\"b\".png".into()),
            hands: vec![hand(HandSide::Right, Some(3), 500.0), two_d],
            ..Default::default()
        };
        let rows = csv_rows(&frame);
        assert_eq!(rows.len(), 2);
        assert!(
            rows[0].starts_with("7,\"a,\"\"b\"\".png\",3,right,0.97,,100,50.5,0.75,0,0,500,"),
            "{}",
            rows[0]
        );
        assert!(
            rows[1].starts_with("7,\"a,\"\"b\"\".png\",,left,,,100,50.5,0.75,,,,101,"),
            "{}",
            rows[1]
        );
        // Same number of fields as the header (the quoted source holds one comma).
        assert_eq!(rows[0].split(',').count(), cols.len() + 1);
        assert_eq!(rows[1].split(',').count(), cols.len() + 1);
        assert!(csv_rows(&FrameRecord::default()).is_empty());
    }

    #[test]
    fn csv_writer_flushes_each_frame() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        let mut w = CsvWriter::create(&path).unwrap();
        let f = FrameRecord {
            frame: 0,
            hands: vec![hand(HandSide::Left, Some(1), 300.0)],
            ..Default::default()
        };
        w.write_frame(&f).unwrap();
        // Readable before the writer is dropped.
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.lines().count(), 2);
        assert_eq!(text.lines().next(), Some(csv_header().as_str()));
        w.write_frame(&FrameRecord::default()).unwrap();
        assert_eq!(w.rows_written(), 1);
        let e = CsvWriter::create(dir.path().join("no/dir/x.csv")).unwrap_err();
        assert!(e.to_string().contains("x.csv"), "{e}");
    }
}
