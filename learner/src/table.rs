//! CSV tables the metric works on: feature matrices (`id,<name>...`, as written by
//! `learner features`) and style labels (`file,style,concept,...`).
//!
//! Readers take any `std::io::Read` plus the name to show in errors, so a bad row is reported as
//! `file:line: what is wrong` (the 1-based line of the CSV text, header = line 1). Non-finite
//! feature values are rejected: a NaN would silently poison every distance it touches.

use std::collections::HashMap;
use std::io::{Read, Write};
use std::path::Path;

use crate::{Error, Result};

/// A dense feature matrix: one row per item, one column per named feature.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureTable {
    names: Vec<String>,
    ids: Vec<String>,
    values: Vec<f64>,
    index: HashMap<String, usize>,
}

impl FeatureTable {
    /// Builds a table from row-major `values` (`ids.len() × names.len()`). Fails on a shape
    /// mismatch, duplicate ids or non-finite values.
    pub fn new(names: Vec<String>, ids: Vec<String>, values: Vec<f64>) -> Result<Self> {
        if values.len() != ids.len() * names.len() {
            return Err(Error::InvalidParameter {
                name: "values",
                value: values.len().to_string(),
                reason: "length must be ids × names",
            });
        }
        if let Some(v) = values.iter().find(|v| !v.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "values",
                value: v.to_string(),
                reason: "features must be finite",
            });
        }
        let mut index = HashMap::with_capacity(ids.len());
        for (i, id) in ids.iter().enumerate() {
            if index.insert(id.clone(), i).is_some() {
                return Err(Error::InvalidParameter {
                    name: "ids",
                    value: id.clone(),
                    reason: "duplicate id",
                });
            }
        }
        Ok(Self {
            names,
            ids,
            values,
            index,
        })
    }

    /// Feature (column) names.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Item ids, in row order.
    pub fn ids(&self) -> &[String] {
        &self.ids
    }

    /// Number of items (rows).
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// True when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Number of features (columns).
    pub fn dim(&self) -> usize {
        self.names.len()
    }

    /// Row `i`.
    ///
    /// # Panics
    /// If `i >= self.len()`.
    pub fn row(&self, i: usize) -> &[f64] {
        let p = self.dim();
        &self.values[i * p..(i + 1) * p]
    }

    /// The row-major values.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The row of an id.
    pub fn index_of(&self, id: &str) -> Option<usize> {
        self.index.get(id).copied()
    }
}

pub(crate) fn csv_error(path: &Path, line: u64, message: impl Into<String>) -> Error {
    Error::InvalidCsv {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

pub(crate) fn record_line(record: &csv::StringRecord) -> u64 {
    record.position().map_or(0, |p| p.line())
}

pub(crate) fn from_csv_error(path: &Path, e: csv::Error) -> Error {
    let line = e.position().map_or(0, |p| p.line());
    match e.into_kind() {
        csv::ErrorKind::Io(source) => Error::Io {
            path: path.to_path_buf(),
            source,
        },
        kind => csv_error(path, line, format!("{kind:?}")),
    }
}

pub(crate) fn open(path: &Path) -> Result<std::fs::File> {
    std::fs::File::open(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

pub(crate) fn create(path: &Path) -> Result<std::fs::File> {
    std::fs::File::create(path).map_err(|source| Error::CannotWrite {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a features CSV (`id,<name>...`; any names, at least one) from a file.
pub fn read_features(path: &Path) -> Result<FeatureTable> {
    read_features_from(open(path)?, path)
}

/// Reads a features CSV from `reader`; `path` names the source in errors.
pub fn read_features_from<R: Read>(reader: R, path: &Path) -> Result<FeatureTable> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(reader);
    let header = rdr.headers().map_err(|e| from_csv_error(path, e))?.clone();
    if header.is_empty() || header.iter().all(str::is_empty) {
        return Err(Error::EmptyFile {
            path: path.to_path_buf(),
        });
    }
    if header.get(0) != Some("id") {
        return Err(csv_error(
            path,
            1,
            format!(
                "first column must be `id`, found `{}`",
                header.get(0).unwrap_or("")
            ),
        ));
    }
    if header.len() < 2 {
        return Err(csv_error(path, 1, "no feature columns after `id`"));
    }
    let names: Vec<String> = header.iter().skip(1).map(str::to_owned).collect();
    let mut ids = Vec::new();
    let mut values = Vec::new();
    let mut seen: HashMap<String, u64> = HashMap::new();
    for record in rdr.records() {
        let record = record.map_err(|e| from_csv_error(path, e))?;
        let line = record_line(&record);
        let id = record.get(0).unwrap_or("").to_owned();
        if id.is_empty() {
            return Err(csv_error(path, line, "empty id"));
        }
        if let Some(first) = seen.insert(id.clone(), line) {
            return Err(csv_error(
                path,
                line,
                format!("duplicate id `{id}` (first on line {first})"),
            ));
        }
        for (j, field) in record.iter().enumerate().skip(1) {
            let v: f64 = field.trim().parse().map_err(|_| {
                csv_error(
                    path,
                    line,
                    format!("column `{}`: `{field}` is not a number", names[j - 1]),
                )
            })?;
            if !v.is_finite() {
                return Err(csv_error(
                    path,
                    line,
                    format!("column `{}`: value {v} is not finite", names[j - 1]),
                ));
            }
            values.push(v);
        }
        ids.push(id);
    }
    if ids.is_empty() {
        return Err(Error::EmptyFile {
            path: path.to_path_buf(),
        });
    }
    FeatureTable::new(names, ids, values)
}

/// Writes a features CSV (`id,<name>...`), values with full `f64` round-trip precision.
pub fn write_features_to<W: Write>(table: &FeatureTable, writer: W, path: &Path) -> Result<()> {
    let mut wtr = csv::Writer::from_writer(writer);
    let io = |e: csv::Error| from_csv_error(path, e);
    wtr.write_record(std::iter::once("id").chain(table.names().iter().map(String::as_str)))
        .map_err(io)?;
    for i in 0..table.len() {
        let mut rec = vec![table.ids()[i].clone()];
        rec.extend(table.row(i).iter().map(|v| v.to_string()));
        wtr.write_record(&rec).map_err(io)?;
    }
    wtr.flush().map_err(|source| Error::CannotWrite {
        path: path.to_path_buf(),
        source,
    })
}

/// One row of a labels file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Label {
    /// The item id (the `file` column, e.g. `noto/dog-face.svg`).
    pub id: String,
    /// Its style group.
    pub style: String,
    /// Its concept (empty when the file has no `concept` column).
    pub concept: String,
}

/// Reads a labels CSV with columns `file` (or `id`) and `style`, optionally `concept`; other
/// columns are ignored.
pub fn read_labels(path: &Path) -> Result<Vec<Label>> {
    read_labels_from(open(path)?, path)
}

/// Reads a labels CSV from `reader`; `path` names the source in errors.
pub fn read_labels_from<R: Read>(reader: R, path: &Path) -> Result<Vec<Label>> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(false)
        .from_reader(reader);
    let header = rdr.headers().map_err(|e| from_csv_error(path, e))?.clone();
    let col = |name: &str| header.iter().position(|h| h == name);
    let id_col = col("file")
        .or_else(|| col("id"))
        .ok_or_else(|| csv_error(path, 1, "no `file` (or `id`) column"))?;
    let style_col = col("style").ok_or_else(|| csv_error(path, 1, "no `style` column"))?;
    let concept_col = col("concept");
    let mut out = Vec::new();
    let mut seen: HashMap<String, u64> = HashMap::new();
    for record in rdr.records() {
        let record = record.map_err(|e| from_csv_error(path, e))?;
        let line = record_line(&record);
        let id = record.get(id_col).unwrap_or("").to_owned();
        let style = record.get(style_col).unwrap_or("").to_owned();
        if id.is_empty() || style.is_empty() {
            return Err(csv_error(path, line, "empty id or style"));
        }
        if let Some(first) = seen.insert(id.clone(), line) {
            return Err(csv_error(
                path,
                line,
                format!("duplicate id `{id}` (first on line {first})"),
            ));
        }
        let concept = concept_col
            .and_then(|c| record.get(c))
            .unwrap_or("")
            .to_owned();
        out.push(Label { id, style, concept });
    }
    if out.is_empty() {
        return Err(Error::EmptyFile {
            path: path.to_path_buf(),
        });
    }
    Ok(out)
}

/// Writes labels as `file,style,concept`.
pub fn write_labels(labels: &[Label], path: &Path) -> Result<()> {
    let mut wtr = csv::Writer::from_writer(create(path)?);
    let io = |e: csv::Error| from_csv_error(path, e);
    wtr.write_record(["file", "style", "concept"]).map_err(io)?;
    for l in labels {
        wtr.write_record([&l.id, &l.style, &l.concept])
            .map_err(io)?;
    }
    wtr.flush().map_err(|source| Error::CannotWrite {
        path: path.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<FeatureTable> {
        read_features_from(text.as_bytes(), Path::new("f.csv"))
    }

    #[test]
    fn reads_any_header() {
        let t = read("id,a,b\nx,1,2\ny,3.5,-4e-1\n").unwrap();
        assert_eq!(t.names(), ["a", "b"]);
        assert_eq!(t.row(1), [3.5, -0.4]);
        assert_eq!(t.index_of("y"), Some(1));
    }

    #[test]
    fn nan_names_file_and_line() {
        let e = read("id,a,b\nx,1,2\ny,NaN,3\n").unwrap_err().to_string();
        assert!(e.starts_with("f.csv:3:"), "{e}");
        assert!(e.contains("not finite"), "{e}");
    }

    #[test]
    fn bad_number_and_duplicates_and_empty() {
        let e = read("id,a\nx,abc\n").unwrap_err().to_string();
        assert!(
            e.starts_with("f.csv:2:") && e.contains("not a number"),
            "{e}"
        );
        let e = read("id,a\nx,1\nx,2\n").unwrap_err().to_string();
        assert!(e.contains("f.csv:3:") && e.contains("duplicate"), "{e}");
        assert!(matches!(read("id,a\n"), Err(Error::EmptyFile { .. })));
        assert!(matches!(read(""), Err(Error::EmptyFile { .. })));
        let e = read("name,a\nx,1\n").unwrap_err().to_string();
        assert!(e.contains("first column must be `id`"), "{e}");
        let e = read("id,a,b\nx,1\n").unwrap_err().to_string();
        assert!(e.contains("f.csv:2"), "{e}");
    }

    #[test]
    fn labels_round_trip() {
        let text = "file,style,concept,license\nn/a.svg,n,a,x\nt/a.svg,t,a,y\n";
        let l = read_labels_from(text.as_bytes(), Path::new("l.csv")).unwrap();
        assert_eq!(l[1].style, "t");
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("l.csv");
        write_labels(&l, &p).unwrap();
        assert_eq!(read_labels(&p).unwrap(), l);
        let e = read_labels_from("file,concept\na,b\n".as_bytes(), Path::new("l.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("no `style` column"), "{e}");
    }

    #[test]
    fn features_round_trip() {
        let t = read("id,a,b\nx,0.1,2\ny,3.5,-4e-1\n").unwrap();
        let mut buf = Vec::new();
        write_features_to(&t, &mut buf, Path::new("o.csv")).unwrap();
        assert_eq!(read_features_from(&buf[..], Path::new("o.csv")).unwrap(), t);
    }
}
