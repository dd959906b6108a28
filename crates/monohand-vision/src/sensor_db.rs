//! Sensor widths by camera make and model: the width of a camera's image in mm, which turns
//! the focal length in mm that every camera writes into its EXIF into one in pixels of any
//! copy of the photo, resized or not: `fx = f_mm * image width / sensor width`.
//!
//! The data is `data/sensor_widths.csv`, embedded at build time: COLMAP's camera database
//! (`src/colmap/sensor/specs.cc`, BSD-3-Clause; the file names the commit and keeps the
//! licence notice), converted by `tools/sensor_db_from_colmap.py`. Widths are the longer side
//! of the sensor's image area, mm.
//!
//! Names are matched as COLMAP matches them: lower case, without spaces and dashes, the make
//! removed from the model (EXIF `Canon` / `Canon EOS 5DS R` is `canon` / `eos5dsr`); an
//! exact model wins, else a model that contains, or is contained in, exactly one entry of
//! the make.

use std::sync::OnceLock;

/// The database, as embedded.
const DATA: &str = include_str!("../data/sensor_widths.csv");

/// One camera of the database.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorEntry {
    /// The make, cleaned ([`clean`]).
    pub make: String,
    /// The model, cleaned ([`clean`]).
    pub model: String,
    /// The width of the sensor's image area (its longer side), mm.
    pub width_mm: f64,
}

/// A make or model as the database spells it: lower case, without white space and dashes.
pub fn clean(name: &str) -> String {
    name.chars()
        .filter(|c| !c.is_whitespace() && *c != '-' && *c != '\0')
        .flat_map(char::to_lowercase)
        .collect()
}

/// Reads a database in the format of `data/sensor_widths.csv`: `#` comments, a header
/// `make;model;sensor_width_mm`, then one camera a line. Lines that are not three fields
/// with a positive finite width are skipped.
pub fn parse(text: &str) -> Vec<SensorEntry> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .filter_map(|line| {
            let mut fields = line.split(';');
            let (make, model, width) = (fields.next()?, fields.next()?, fields.next()?);
            if fields.next().is_some() {
                return None;
            }
            let width_mm: f64 = width.trim().parse().ok()?;
            (width_mm.is_finite() && width_mm > 0.0).then(|| SensorEntry {
                make: clean(make),
                model: clean(model),
                width_mm,
            })
        })
        .collect()
}

/// The embedded database ([`parse`] of `data/sensor_widths.csv`).
pub fn entries() -> &'static [SensorEntry] {
    static DB: OnceLock<Vec<SensorEntry>> = OnceLock::new();
    DB.get_or_init(|| parse(DATA))
}

/// The camera of this EXIF `Make` and `Model` in the embedded database, if it has it
/// (see the module docs for the matching).
pub fn lookup(make: &str, model: &str) -> Option<&'static SensorEntry> {
    lookup_in(entries(), make, model)
}

/// [`lookup`] in a given database.
pub fn lookup_in<'a>(db: &'a [SensorEntry], make: &str, model: &str) -> Option<&'a SensorEntry> {
    let make = clean(make);
    let model = clean(model);
    if make.is_empty() || model.is_empty() {
        return None;
    }
    let mut found: Option<&SensorEntry> = None;
    let mut partial = 0usize;
    for e in db {
        if e.make.is_empty() || !(make.contains(&e.make) || e.make.contains(&make)) {
            continue;
        }
        // The model without the make (`canoneos5dsr` -> `eos5dsr`).
        let m = model.replace(&e.make, "");
        let m = if m.is_empty() { model.as_str() } else { &m };
        if e.model == m {
            return Some(e);
        }
        // A partial match needs a few characters either way: `d8` must not stand for `d850`.
        let shorter = m.len().min(e.model.len());
        if shorter >= 3 && (m.contains(&e.model) || e.model.contains(m)) {
            partial += 1;
            found = Some(e);
        }
    }
    (partial == 1).then_some(found).flatten()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_database_parses_whole() {
        // Every data line is a camera: nothing is skipped as malformed.
        let data_lines = DATA
            .lines()
            .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
            .count();
        // The header is the one line skipped.
        assert_eq!(entries().len(), data_lines - 1);
        assert!(entries().len() > 4000, "{}", entries().len());
        assert!(entries()
            .iter()
            .all(|e| e.width_mm > 1.0 && e.width_mm < 60.0));
    }

    #[test]
    fn exif_names_are_found() {
        // hamer/test1.jpg: Make `Canon`, Model `Canon EOS 5DS R`.
        let e = lookup("Canon", "Canon EOS 5DS R").expect("the 5DS R");
        assert_eq!((e.model.as_str(), e.width_mm), ("eos5dsr", 36.0));
        // Not the 5DS (an exact model wins over a contained one).
        assert_eq!(
            lookup("Canon", "Canon EOS 5DS").map(|e| e.model.as_str()),
            Some("eos5ds")
        );
        // Makes spelled as companies, models with the make in them.
        let n = lookup("NIKON CORPORATION", "NIKON D850");
        assert!(n.is_some_and(|e| (e.width_mm - 35.9).abs() < 0.2), "{n:?}");
        assert_eq!(
            lookup("Apple", "iPhone 11 Pro").map(|e| e.width_mm),
            Some(5.76)
        );
        // Unknown cameras, and empty or absurd names, are not found.
        assert!(lookup("Canon", "").is_none());
        assert!(lookup("", "EOS 5DS R").is_none());
        assert!(lookup("NoSuchMaker", "X1").is_none());
        assert!(lookup("Canon", "E").is_none());
    }

    #[test]
    fn malformed_lines_are_skipped() {
        let db = parse("# c\nmake;model;sensor_width_mm\na;b;1.5\na;c;-2\na;d\na;e;1;2\na;f;nan\n");
        assert_eq!(db.len(), 1);
        assert_eq!(lookup_in(&db, "A", "B").map(|e| e.width_mm), Some(1.5));
    }
}
