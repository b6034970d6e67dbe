//! Importing folders of SVG/raster files and Iconify icon sets into a library, with an optional
//! labels CSV. Every input is either stored, found already present, or listed with the file and
//! the reason it was skipped: one bad drawing never stops the others.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use learner::input::{Item, Source};

use super::{ImportReport, Inserted, NewItem, ensure_library, insert_item};
use crate::error::{AppError, Result};
use crate::store::db::Db;

/// The rows of a labels CSV (`file` and `style` columns; `keywords`, `;`- or `,`-separated, when
/// present), as the researcher wrote them.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Labels {
    /// Style label by file (rows with an empty style are left out).
    pub styles: HashMap<String, String>,
    /// Keywords by file.
    pub keywords: HashMap<String, Vec<String>>,
    /// Every row's (line, file), in file order; `file` may be empty.
    pub rows: Vec<(u64, String)>,
}

/// Reads a labels CSV (the fixture's `labels.csv`): `file` and `style` columns are required.
pub fn read_labels(path: &Path) -> Result<Labels> {
    let bad = |e: &dyn std::fmt::Display| AppError::BadRequest(format!("{}: {e}", path.display()));
    let mut reader = csv::Reader::from_path(path).map_err(|e| bad(&e))?;
    let headers = reader.headers().map_err(|e| bad(&e))?.clone();
    let column = |name: &str| headers.iter().position(|h| h.trim() == name);
    let (Some(file_col), Some(style_col)) = (column("file"), column("style")) else {
        return Err(bad(&"needs 'file' and 'style' columns"));
    };
    let keywords_col = column("keywords");
    let mut labels = Labels::default();
    for (row, record) in reader.records().enumerate() {
        let line = row as u64 + 2;
        let record = record.map_err(|e| bad(&format!("line {line}: {e}")))?;
        let file = record.get(file_col).unwrap_or_default().trim().to_string();
        labels.rows.push((line, file.clone()));
        if file.is_empty() {
            continue;
        }
        let style = record.get(style_col).unwrap_or_default().trim();
        if !style.is_empty() {
            labels.styles.insert(file.clone(), style.to_string());
        }
        if let Some(k) = keywords_col.and_then(|c| record.get(c)) {
            let words: Vec<String> = k
                .split([';', ','])
                .map(|w| w.trim().to_string())
                .filter(|w| !w.is_empty())
                .collect();
            if !words.is_empty() {
                labels.keywords.insert(file, words);
            }
        }
    }
    Ok(labels)
}

/// Where an item comes from, as the researcher named it: the file, or the icon of an Iconify set.
fn location(item: &Item) -> String {
    match &item.source {
        Source::SvgFile(p) | Source::RasterFile(p) => p.display().to_string(),
        Source::SvgText(_) => format!("Iconify icon {}", item.id),
    }
}

/// The warnings a labels CSV earns against the items found: rows that name no file, and rows
/// whose file is not among the inputs (a typo, or a file left out), so their labels went
/// nowhere.
fn label_warnings(labels: &Labels, path: &Path, found: &HashSet<&str>) -> Vec<String> {
    labels
        .rows
        .iter()
        .filter_map(|(line, file)| {
            if file.is_empty() {
                Some(format!(
                    "{} line {line}: the row names no file",
                    path.display()
                ))
            } else if !found.contains(file.as_str()) {
                Some(format!(
                    "{} line {line}: no input file is named {file:?}; its labels are unused",
                    path.display()
                ))
            } else {
                None
            }
        })
        .collect()
}

/// Imports SVG/raster folders and Iconify JSON files into the library `name`. `labels` is an
/// optional CSV with `file,style[,keywords]` columns (style labels and keywords by item id).
/// Items that cannot be used (unreadable, malformed, blank) are listed in the report's
/// `skipped` with the file and the reason, and every other item is still stored.
pub async fn import_paths(
    db: &Db,
    name: &str,
    paths: &[PathBuf],
    labels: Option<&Path>,
) -> Result<ImportReport> {
    let library = ensure_library(db, name).await?;
    let label_rows = match labels {
        Some(p) => read_labels(p)?,
        None => Labels::default(),
    };
    let inputs = paths.to_vec();
    let discovery = tokio::task::spawn_blocking(move || learner::input::discover(&inputs, None))
        .await
        .map_err(AppError::internal)?
        .map_err(|e| AppError::BadRequest(e.to_string()))?;
    let found: HashSet<&str> = discovery.items.iter().map(|i| i.id.as_str()).collect();
    let mut report = ImportReport {
        library: Some(library),
        skipped: discovery
            .errors
            .iter()
            .map(|e| (e.location.clone(), e.error.to_string()))
            .collect(),
        warnings: labels.map_or_else(Vec::new, |p| label_warnings(&label_rows, p, &found)),
        ..ImportReport::default()
    };
    for mut item in discovery.items {
        let at = location(&item);
        if item.tags.is_empty()
            && let Some(words) = label_rows.keywords.get(&item.id)
        {
            item.tags = words.clone();
        }
        let rendered = tokio::task::spawn_blocking(move || {
            // A raster is decoded once: its cut-out, flattened onto white for the features.
            let cutout = item.render_cutout()?;
            let image = match &cutout {
                Some(c) => learner::render::flatten_on_white(c),
                None => item.render()?,
            };
            let svg = match &item.source {
                Source::SvgFile(path) => {
                    let bytes = std::fs::read(path).map_err(|source| learner::Error::Io {
                        path: path.clone(),
                        source,
                    })?;
                    Some(super::svg_source(&bytes)?)
                }
                Source::SvgText(text) => Some(super::svg_source(text.as_bytes())?),
                Source::RasterFile(_) => None,
            };
            Ok::<_, learner::Error>((item, image, cutout, svg))
        })
        .await
        .map_err(AppError::internal)?;
        let (item, image, cutout, svg) = match rendered {
            Ok(r) => r,
            Err(e) => {
                report.skipped.push((at, e.to_string()));
                continue;
            }
        };
        let new = NewItem {
            style: label_rows.styles.get(&item.id).cloned(),
            name: item.id,
            tags: item.tags,
            image,
            cutout,
            svg,
        };
        match insert_item(db, library, new).await? {
            Inserted::New(_) => report.imported += 1,
            Inserted::AlreadyPresent => report.existing += 1,
            Inserted::Unusable(reason) => report.skipped.push((at, reason)),
        }
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_rows_that_name_no_input_are_warned_about() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("labels.csv");
        std::fs::write(
            &path,
            "file,style,keywords\na.svg,flat,dog;tree\n,flat,\nmissing.svg,ink,\nb.svg,,sun\n",
        )
        .expect("write");
        let labels = read_labels(&path).expect("labels");
        assert_eq!(labels.styles.get("a.svg").map(String::as_str), Some("flat"));
        assert!(
            !labels.styles.contains_key("b.svg"),
            "an empty style is no label"
        );
        assert_eq!(labels.keywords["a.svg"], ["dog", "tree"]);
        assert_eq!(labels.keywords["b.svg"], ["sun"]);
        let found: HashSet<&str> = ["a.svg", "b.svg"].into_iter().collect();
        let warnings = label_warnings(&labels, &path, &found);
        assert_eq!(warnings.len(), 2, "{warnings:?}");
        assert!(
            warnings[0].contains("line 3: the row names no file"),
            "{warnings:?}"
        );
        assert!(warnings[1].contains("line 4") && warnings[1].contains("missing.svg"));
    }

    #[test]
    fn a_labels_file_without_a_style_column_is_refused() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("labels.csv");
        std::fs::write(&path, "file,keywords\na.svg,dog\n").expect("write");
        let err = read_labels(&path).expect_err("no style column");
        assert!(err.to_string().contains("'file' and 'style'"), "{err}");
    }
}
