//! The items an exploration works on: their rows in the learned style space (`√w ⊙ x̂`,
//! eq. 5.5, so that Euclidean distance is the learned metric) and the semantic label of each
//! (its category: "dog", "tree", …), optionally kept to a few requested labels (§6.5: the user
//! picks the labels a set of images must show).

use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::Path;

use crate::search::StyleMatrix;
use crate::search::index::LANES;
use crate::table::{FeatureTable, csv_error, from_csv_error, open, record_line};
use crate::{Error, Result};

/// The label given to items that the item-labels file does not list.
pub const UNLABELLED: &str = "unlabelled";

/// Items with their style rows and semantic labels.
#[derive(Debug, Clone, PartialEq)]
pub struct StyleLibrary {
    ids: Vec<String>,
    /// Row-major `len × dim`.
    points: Vec<f32>,
    dim: usize,
    /// Index into `label_names` of each item.
    labels: Vec<u32>,
    label_names: Vec<String>,
}

impl StyleLibrary {
    /// Items from parts. Errors: lengths that do not agree, a label index out of range, no items.
    pub fn new(
        ids: Vec<String>,
        points: Vec<f32>,
        dim: usize,
        labels: Vec<u32>,
        label_names: Vec<String>,
    ) -> Result<Self> {
        if ids.is_empty() {
            return Err(Error::EmptyLibrary);
        }
        if dim == 0 || points.len() != ids.len() * dim || labels.len() != ids.len() {
            return Err(Error::NotAMatrix {
                len: points.len(),
                dim,
            });
        }
        if labels.iter().any(|&l| l as usize >= label_names.len()) {
            return Err(Error::InvalidParameter {
                name: "labels",
                value: format!("{} names", label_names.len()),
                reason: "every item's label must index the label names",
            });
        }
        Ok(Self {
            ids,
            points,
            dim,
            labels,
            label_names,
        })
    }

    /// The rows of `matrix` (built from `table`), each item labelled by `item_labels` (id →
    /// label; unlisted items are [`UNLABELLED`]; `None` puts every item under one label "all"),
    /// kept to the items whose label is in `keep` when given. Errors: a requested label that no
    /// item has (the message lists the library's labels), or no item left.
    pub fn from_matrix(
        table: &FeatureTable,
        matrix: &StyleMatrix,
        item_labels: Option<&HashMap<String, String>>,
        keep: Option<&[String]>,
    ) -> Result<Self> {
        let label_of = |id: &str| -> &str {
            match item_labels {
                None => "all",
                Some(map) => map.get(id).map_or(UNLABELLED, String::as_str),
            }
        };
        let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
        for id in table.ids() {
            *counts.entry(label_of(id)).or_default() += 1;
        }
        if let Some(keep) = keep {
            let missing: Vec<String> = keep
                .iter()
                .filter(|l| !counts.contains_key(l.as_str()))
                .cloned()
                .collect();
            if !missing.is_empty() {
                let mut known: Vec<(&str, usize)> = counts.iter().map(|(l, c)| (*l, *c)).collect();
                known.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
                return Err(Error::UnknownLabels {
                    missing,
                    known: known
                        .iter()
                        .take(20)
                        .map(|(l, _)| (*l).to_owned())
                        .collect(),
                    total: known.len(),
                });
            }
        }
        let label_names: Vec<String> = match keep {
            Some(keep) => {
                let mut names: Vec<String> = Vec::new();
                for l in keep {
                    if !names.contains(l) {
                        names.push(l.clone());
                    }
                }
                names
            }
            None => counts.keys().map(|l| (*l).to_owned()).collect(),
        };
        let index: HashMap<&str, u32> = label_names
            .iter()
            .enumerate()
            .map(|(i, l)| (l.as_str(), i as u32))
            .collect();
        let dim = matrix.stride();
        let (mut ids, mut points, mut labels) = (Vec::new(), Vec::new(), Vec::new());
        for (i, id) in table.ids().iter().enumerate() {
            if let Some(&l) = index.get(label_of(id)) {
                ids.push(id.clone());
                points.extend_from_slice(matrix.row(i));
                labels.push(l);
            }
        }
        Self::new(ids, points, dim, labels, label_names)
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// True when there are no items (never, for a constructed library).
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Coordinates per row (the style space's stored dimensions, zero-padded).
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Item ids, in row order.
    pub fn ids(&self) -> &[String] {
        &self.ids
    }

    /// Row-major rows.
    pub fn points(&self) -> &[f32] {
        &self.points
    }

    /// Row `i`.
    pub fn row(&self, i: usize) -> &[f32] {
        &self.points[i * self.dim..(i + 1) * self.dim]
    }

    /// Label index of each item.
    pub fn labels(&self) -> &[u32] {
        &self.labels
    }

    /// Label names (the requested ones in the order given, else every label sorted).
    pub fn label_names(&self) -> &[String] {
        &self.label_names
    }

    /// The rows of `items`, each zero-padded to a multiple of the scan kernel's [`LANES`] (the
    /// layout `search::kmeans` needs), and that stride.
    pub(crate) fn padded_rows(&self, items: &[usize]) -> (Vec<f32>, usize) {
        let stride = self.dim.div_ceil(LANES) * LANES;
        let mut rows = vec![0.0f32; items.len() * stride];
        for (k, &i) in items.iter().enumerate() {
            rows[k * stride..k * stride + self.dim].copy_from_slice(self.row(i));
        }
        (rows, stride)
    }

    /// The items `keep` (indices into this library) as a library of their own.
    pub fn subset(&self, keep: &[usize]) -> Result<Self> {
        if let Some(&bad) = keep.iter().find(|&&i| i >= self.len()) {
            return Err(Error::InvalidParameter {
                name: "items",
                value: bad.to_string(),
                reason: "an item index beyond the library",
            });
        }
        Self::new(
            keep.iter().map(|&i| self.ids[i].clone()).collect(),
            keep.iter().flat_map(|&i| self.row(i)).copied().collect(),
            self.dim,
            keep.iter().map(|&i| self.labels[i]).collect(),
            self.label_names.clone(),
        )
    }
}

/// Reads the semantic label of each item: a CSV with an id column (`id` or `file`) and a label
/// column (`column`, or else `label`, `category`, `concept` or `group`, the first present).
/// Items with an empty label are left out (they count as [`UNLABELLED`]). Errors: no such
/// columns, an empty id, a duplicate id, no labelled row.
pub fn read_item_labels(path: &Path, column: Option<&str>) -> Result<HashMap<String, String>> {
    read_item_labels_from(open(path)?, path, column)
}

/// [`read_item_labels`] from a reader; `path` names the source in errors.
pub fn read_item_labels_from<R: Read>(
    reader: R,
    path: &Path,
    column: Option<&str>,
) -> Result<HashMap<String, String>> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(false)
        .from_reader(reader);
    let header = rdr.headers().map_err(|e| from_csv_error(path, e))?.clone();
    let col = |name: &str| header.iter().position(|h| h == name);
    let id_col = col("id")
        .or_else(|| col("file"))
        .ok_or_else(|| csv_error(path, 1, "no `id` (or `file`) column"))?;
    let label_col = match column {
        Some(name) => col(name).ok_or_else(|| csv_error(path, 1, format!("no `{name}` column")))?,
        None => ["label", "category", "concept", "group"]
            .iter()
            .find_map(|name| col(name))
            .ok_or_else(|| {
                csv_error(
                    path,
                    1,
                    "no `label` column (nor `category`, `concept`, `group`)",
                )
            })?,
    };
    let mut out = HashMap::new();
    let mut first_line: HashMap<String, u64> = HashMap::new();
    for record in rdr.records() {
        let record = record.map_err(|e| from_csv_error(path, e))?;
        let line = record_line(&record);
        let id = record.get(id_col).unwrap_or("").trim().to_owned();
        let label = record.get(label_col).unwrap_or("").trim().to_owned();
        if id.is_empty() {
            return Err(csv_error(path, line, "empty id"));
        }
        if let Some(first) = first_line.insert(id.clone(), line) {
            return Err(csv_error(
                path,
                line,
                format!("duplicate id `{id}` (first on line {first})"),
            ));
        }
        // An item with an empty label is left out: it counts as unlabelled.
        if !label.is_empty() {
            out.insert(id, label);
        }
    }
    if out.is_empty() {
        return Err(Error::EmptyFile {
            path: path.to_path_buf(),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::search::Weighting;

    fn table() -> FeatureTable {
        let ids = ["a", "b", "c", "d"].map(String::from).to_vec();
        let values = vec![0.0, 1.0, 1.0, 0.0, 2.0, 2.0, 3.0, 1.0];
        FeatureTable::new(vec!["f".into(), "g".into()], ids, values).unwrap()
    }

    #[test]
    fn explore_library_keeps_the_requested_labels_only() {
        let t = table();
        let m = StyleMatrix::build(&t, &Weighting::uniform(&t)).unwrap();
        let labels: HashMap<String, String> = [("a", "dog"), ("b", "tree"), ("c", "dog")]
            .map(|(i, l)| (i.to_owned(), l.to_owned()))
            .into();
        let all = StyleLibrary::from_matrix(&t, &m, Some(&labels), None).unwrap();
        assert_eq!(all.label_names(), ["dog", "tree", UNLABELLED]);
        assert_eq!(all.labels(), [0, 1, 0, 2]);
        let keep = ["tree".to_owned(), "dog".to_owned()];
        let some = StyleLibrary::from_matrix(&t, &m, Some(&labels), Some(&keep)).unwrap();
        assert_eq!(some.ids(), ["a", "b", "c"]);
        assert_eq!(some.labels(), [1, 0, 1]);
        assert_eq!(some.row(1), m.row(1));
        let err = StyleLibrary::from_matrix(&t, &m, Some(&labels), Some(&["cat".into()]))
            .unwrap_err()
            .to_string();
        assert!(err.contains("cat") && err.contains("dog"), "{err}");
        let one = StyleLibrary::from_matrix(&t, &m, None, None).unwrap();
        assert_eq!(one.label_names(), ["all"]);
        assert_eq!(one.subset(&[3, 0]).unwrap().ids(), ["d", "a"]);
        assert!(one.subset(&[4]).is_err());
    }

    #[test]
    fn explore_item_labels_csv_errors_are_clear() {
        let p = Path::new("labels.csv");
        let ok = read_item_labels_from("file,group\nx.svg,animals\n".as_bytes(), p, None).unwrap();
        assert_eq!(ok["x.svg"], "animals");
        let pick =
            read_item_labels_from("id,label,group\nx,a,b\n".as_bytes(), p, Some("group")).unwrap();
        assert_eq!(pick["x"], "b");
        let partly = read_item_labels_from("id,label\nx,\ny,a\n".as_bytes(), p, None).unwrap();
        assert_eq!(partly.len(), 1);
        for (text, needle) in [
            ("name,label\nx,a\n", "no `id`"),
            ("id,colour\nx,a\n", "no `label`"),
            ("id,label\n,a\n", "empty id"),
            ("id,label\nx,a\nx,b\n", "duplicate id `x`"),
        ] {
            let err = read_item_labels_from(text.as_bytes(), p, None)
                .unwrap_err()
                .to_string();
            assert!(err.contains(needle), "{text:?}: {err}");
        }
        assert!(read_item_labels_from("id,label\n".as_bytes(), p, None).is_err());
    }
}
