//! The parquet tables of a LeRobot dataset: written by parquet's own writer (one row group,
//! uncompressed, plain columns and lists of them), and the states read back.

use crate::error::IoError;
use parquet::basic::{LogicalType, Repetition, Type as PhysicalType};
use parquet::data_type::{ByteArray, ByteArrayType, DoubleType, FloatType, Int64Type};
use parquet::file::properties::WriterProperties;
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::file::writer::SerializedFileWriter;
use parquet::format::KeyValue;
use parquet::record::{Field, RowAccessor};
use parquet::schema::types::Type;
use std::path::Path;
use std::sync::Arc;

/// A column's values, one per row.
pub(super) enum Column<'a> {
    /// A list of float32 per row (LeRobot's vector features).
    FloatList(&'a [Vec<f32>]),
    /// float32.
    Float(Vec<f32>),
    /// float64.
    Double(Vec<f64>),
    /// int64.
    Int(Vec<i64>),
    /// UTF-8 text.
    Text(Vec<String>),
    /// A list of texts per row.
    TextList(Vec<Vec<String>>),
}

impl Column<'_> {
    fn field(&self, name: &str) -> parquet::errors::Result<Type> {
        let leaf = |name: &str, physical, logical: Option<LogicalType>| {
            Type::primitive_type_builder(name, physical)
                .with_repetition(Repetition::REQUIRED)
                .with_logical_type(logical)
                .build()
        };
        let list = |element: Type| -> parquet::errors::Result<Type> {
            let repeated = Type::group_type_builder("list")
                .with_repetition(Repetition::REPEATED)
                .with_fields(vec![Arc::new(element)])
                .build()?;
            Type::group_type_builder(name)
                .with_repetition(Repetition::REQUIRED)
                .with_logical_type(Some(LogicalType::List))
                .with_fields(vec![Arc::new(repeated)])
                .build()
        };
        let string = Some(LogicalType::String);
        match self {
            Column::FloatList(_) => list(leaf("element", PhysicalType::FLOAT, None)?),
            Column::Float(_) => leaf(name, PhysicalType::FLOAT, None),
            Column::Double(_) => leaf(name, PhysicalType::DOUBLE, None),
            Column::Int(_) => leaf(name, PhysicalType::INT64, None),
            Column::Text(_) => leaf(name, PhysicalType::BYTE_ARRAY, string),
            Column::TextList(_) => list(leaf("element", PhysicalType::BYTE_ARRAY, string)?),
        }
    }
}

/// The definition and repetition levels of a list column of these lengths (the outer list
/// required, its elements required: level 1 for a value, 0 for an empty list).
pub(super) fn list_levels(lengths: impl Iterator<Item = usize>) -> (Vec<i16>, Vec<i16>) {
    let (mut def, mut rep) = (Vec::new(), Vec::new());
    for n in lengths {
        if n == 0 {
            def.push(0);
            rep.push(0);
        }
        for k in 0..n {
            def.push(1);
            rep.push(i16::from(k > 0));
        }
    }
    (def, rep)
}

fn text(values: impl IntoIterator<Item = String>) -> Vec<ByteArray> {
    values
        .into_iter()
        .map(|s| ByteArray::from(s.into_bytes()))
        .collect()
}

fn parquet_error(path: &Path) -> impl Fn(parquet::errors::ParquetError) -> IoError + '_ {
    move |e| IoError::Format {
        file: path.display().to_string(),
        message: format!("parquet: {e}"),
    }
}

/// Writes one row group of `columns` to `path` (uncompressed), with `metadata` key-value
/// pairs in the footer.
pub(super) fn write_table<S: AsRef<str>>(
    path: &Path,
    columns: &[(S, Column<'_>)],
    metadata: Vec<KeyValue>,
) -> Result<(), IoError> {
    let bad = parquet_error(path);
    let fields = columns
        .iter()
        .map(|(name, c)| c.field(name.as_ref()).map(Arc::new))
        .collect::<Result<Vec<_>, _>>()
        .map_err(&bad)?;
    let schema = Type::group_type_builder("schema")
        .with_fields(fields)
        .build()
        .map_err(&bad)?;
    let props = WriterProperties::builder()
        .set_key_value_metadata((!metadata.is_empty()).then_some(metadata))
        .set_created_by(format!("monohand {}", env!("CARGO_PKG_VERSION")))
        .build();
    let file = std::fs::File::create(path).map_err(|error| IoError::Write {
        path: path.to_path_buf(),
        error,
    })?;
    let mut writer =
        SerializedFileWriter::new(file, Arc::new(schema), Arc::new(props)).map_err(&bad)?;
    let mut group = writer.next_row_group().map_err(&bad)?;
    for (_, column) in columns {
        let Some(mut col) = group.next_column().map_err(&bad)? else {
            break;
        };
        match column {
            Column::FloatList(rows) => {
                let values: Vec<f32> = rows.iter().flatten().copied().collect();
                let (def, rep) = list_levels(rows.iter().map(Vec::len));
                col.typed::<FloatType>()
                    .write_batch(&values, Some(&def), Some(&rep))
            }
            Column::Float(v) => col.typed::<FloatType>().write_batch(v, None, None),
            Column::Double(v) => col.typed::<DoubleType>().write_batch(v, None, None),
            Column::Int(v) => col.typed::<Int64Type>().write_batch(v, None, None),
            Column::Text(v) => {
                col.typed::<ByteArrayType>()
                    .write_batch(&text(v.iter().cloned()), None, None)
            }
            Column::TextList(rows) => {
                let (def, rep) = list_levels(rows.iter().map(Vec::len));
                let values = text(rows.iter().flatten().cloned());
                col.typed::<ByteArrayType>()
                    .write_batch(&values, Some(&def), Some(&rep))
            }
        }
        .map_err(&bad)?;
        col.close().map_err(&bad)?;
    }
    group.close().map_err(&bad)?;
    writer.close().map_err(&bad)?;
    Ok(())
}

/// The float32 lists of column `name`, row by row, from a parquet file.
pub(super) fn read_float_lists(path: &Path, name: &str) -> Result<Vec<Vec<f32>>, IoError> {
    let bad = parquet_error(path);
    let file = std::fs::File::open(path).map_err(|error| IoError::Read {
        path: path.to_path_buf(),
        error,
    })?;
    let reader = SerializedFileReader::new(file).map_err(&bad)?;
    let schema = reader.metadata().file_metadata().schema();
    let column = schema
        .get_fields()
        .iter()
        .position(|f| f.name() == name)
        .ok_or_else(|| IoError::Format {
            file: path.display().to_string(),
            message: format!("no column {name:?}"),
        })?;
    let mut rows = Vec::new();
    for row in reader.get_row_iter(None).map_err(&bad)? {
        let row = row.map_err(&bad)?;
        let list = row.get_list(column).map_err(&bad)?;
        let values = list
            .elements()
            .iter()
            .map(|f| match f {
                Field::Float(v) => Ok(*v),
                other => Err(IoError::Format {
                    file: path.display().to_string(),
                    message: format!("column {name:?} holds {other}, not float32"),
                }),
            })
            .collect::<Result<Vec<f32>, IoError>>()?;
        rows.push(values);
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// Levels of a list column: a value each, the first of a row at repetition 0; an
    /// empty list one level-0 entry.
    #[test]
    fn list_levels_mark_each_row_start() {
        let (def, rep) = list_levels([2, 0, 1].into_iter());
        assert_eq!(def, vec![1, 1, 0, 1]);
        assert_eq!(rep, vec![0, 1, 0, 0]);
    }

    /// Lists of floats come back as written, empty ones included; another column's name
    /// is an error.
    #[test]
    fn float_lists_read_back_as_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.parquet");
        let rows = vec![vec![1.5f32, -2.0], vec![], vec![3.25]];
        write_table(
            &path,
            &[
                ("a", Column::Int(vec![1, 2, 3])),
                ("s", Column::FloatList(&rows)),
            ],
            Vec::new(),
        )
        .unwrap();
        assert_eq!(read_float_lists(&path, "s").unwrap(), rows);
        assert!(read_float_lists(&path, "missing").is_err());
        assert!(read_float_lists(&path, "a").is_err());
    }
}
