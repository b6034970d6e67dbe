//! The CSV files' columns (name, kind, meaning: the manifest's data dictionary is made from the
//! same list) and the writer that keeps spreadsheets from running a cell as a formula.

use std::borrow::Cow;

use crate::error::{AppError, Result};

/// What a column can hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    /// Anything, including text from workers, admins or file names.
    Text,
    /// A number the platform computed (or nothing): written as it is, so that `-1` stays a
    /// number for a spreadsheet.
    Number,
}

/// One column of a CSV file.
#[derive(Debug)]
pub(super) struct Column {
    pub(super) name: &'static str,
    pub(super) kind: Kind,
    pub(super) about: &'static str,
}

/// A CSV file's layout.
#[derive(Debug)]
pub(super) struct Table {
    pub(super) file: &'static str,
    /// Whether the file starts with a header line (Prolific's bulk bonus format has none).
    pub(super) header: bool,
    pub(super) columns: &'static [Column],
}

/// The characters after which a spreadsheet reads a cell as a formula (OWASP's CSV injection
/// list), and the quote the cure itself adds: a cell starting with `'` gets a second one, so
/// that removing one leading `'` always gives the value back.
const FORMULA_STARTS: [char; 7] = ['=', '+', '-', '@', '\t', '\r', '\''];

/// A text cell as it is written: with a `'` in front when it starts with a character in
/// [`FORMULA_STARTS`], which spreadsheets take as "this is text" and do not show.
pub fn neutralise(cell: &str) -> Cow<'_, str> {
    if cell.starts_with(FORMULA_STARTS) {
        Cow::Owned(format!("'{cell}"))
    } else {
        Cow::Borrowed(cell)
    }
}

impl Table {
    /// The file's bytes: the header (if any) and the rows, text cells neutralised.
    pub(super) fn csv(&self, rows: &[Vec<String>]) -> Result<Vec<u8>> {
        let mut w = csv::Writer::from_writer(Vec::new());
        if self.header {
            w.write_record(self.columns.iter().map(|c| c.name))
                .map_err(AppError::internal)?;
        }
        for row in rows {
            if row.len() != self.columns.len() {
                return Err(AppError::internal(format!(
                    "{}: a row of {} cells for {} columns",
                    self.file,
                    row.len(),
                    self.columns.len()
                )));
            }
            let cells = row
                .iter()
                .zip(self.columns)
                .map(|(cell, col)| match col.kind {
                    Kind::Text => neutralise(cell),
                    Kind::Number => {
                        debug_assert!(
                            cell.is_empty() || cell.parse::<f64>().is_ok(),
                            "{}: {} is a number column, got {cell:?}",
                            self.file,
                            col.name
                        );
                        Cow::Borrowed(cell.as_str())
                    }
                });
            w.write_record(cells.map(|c| c.into_owned()))
                .map_err(AppError::internal)?;
        }
        w.into_inner().map_err(AppError::internal)
    }

    /// The names of the number columns (the manifest lists them).
    pub(super) fn number_columns(&self) -> Vec<&'static str> {
        self.columns
            .iter()
            .filter(|c| c.kind == Kind::Number)
            .map(|c| c.name)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: Table = Table {
        file: "t.csv",
        header: true,
        columns: &[
            Column {
                name: "name",
                kind: Kind::Text,
                about: "",
            },
            Column {
                name: "n",
                kind: Kind::Number,
                about: "",
            },
        ],
    };

    #[test]
    fn formula_cells_get_a_quote_in_text_columns_only() {
        let rows: Vec<Vec<String>> = [
            ("=HYPERLINK(\"http://x\")", "-1"),
            ("+1.svg", "2"),
            ("-1.svg", "-0.5"),
            ("@SUM(A1)", ""),
            ("\tx", "3"),
            ("\rx", "4"),
            ("'quoted", "5"),
            ("plain-name@x", "6"),
        ]
        .iter()
        .map(|(a, b)| vec![a.to_string(), b.to_string()])
        .collect();
        let bytes = T.csv(&rows).expect("csv");
        let mut r = csv::Reader::from_reader(bytes.as_slice());
        let read: Vec<(String, String)> = r
            .records()
            .map(|x| {
                let x = x.expect("record");
                (x[0].to_string(), x[1].to_string())
            })
            .collect();
        let names: Vec<&str> = read.iter().map(|x| x.0.as_str()).collect();
        assert_eq!(
            names,
            [
                "'=HYPERLINK(\"http://x\")",
                "'+1.svg",
                "'-1.svg",
                "'@SUM(A1)",
                "'\tx",
                "'\rx",
                "''quoted",
                "plain-name@x"
            ]
        );
        let numbers: Vec<&str> = read.iter().map(|x| x.1.as_str()).collect();
        assert_eq!(numbers, ["-1", "2", "-0.5", "", "3", "4", "5", "6"]);
        // Removing one leading quote gives every value back.
        for (row, (name, _)) in rows.iter().zip(&read) {
            let back = name.strip_prefix('\'').filter(|_| name != &row[0]);
            assert_eq!(back.unwrap_or(name), row[0]);
        }
    }

    #[test]
    fn a_table_without_header_writes_rows_only() {
        let t = Table { header: false, ..T };
        let bytes = t.csv(&[vec!["a".into(), "1".into()]]).expect("csv");
        assert_eq!(String::from_utf8(bytes).expect("utf-8"), "a,1\n");
        assert!(t.csv(&[vec!["a".into()]]).is_err(), "short row");
    }
}
