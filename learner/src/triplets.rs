//! Relative-similarity triplets (§5.5 of Garces et al. 2014): CSV I/O, validation against a
//! features table, and the labelled-group generator the paper used for the Microsoft data.
//!
//! CSV: `a,b,c,q[,worker][,tuple_id]`. `q = 1` means a rater judged `a` closer to `b` than to
//! `c`; `q = 0` means closer to `c`. Rows are kept as they are: repeated tuples (several raters)
//! stay separate rows, and [`Triplet::tuple`] groups them for majority votes and grouped folds.
//! A tuple is identified by `tuple_id` when the column exists, else by the unordered question
//! `(a, {b, c})`, so `a,b,c,1` and `a,c,b,0` are two answers to the same question.

use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::table::{FeatureTable, Label, create, open};
use crate::{Error, Result};

/// One answered triplet, with ids resolved to rows of a [`FeatureTable`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Triplet {
    /// Reference item row.
    pub a: u32,
    /// First candidate row.
    pub b: u32,
    /// Second candidate row.
    pub c: u32,
    /// True when `a` was judged closer to `b` (the CSV's `q = 1`).
    pub q: bool,
    /// Dense worker index, when the file has workers.
    pub worker: Option<u32>,
    /// Dense tuple index: rows with the same index answer the same question.
    pub tuple: u32,
}

/// Triplets read from a file, plus what was skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct TripletSet {
    /// The valid rows, in file order.
    pub triplets: Vec<Triplet>,
    /// Rows skipped with `skip_invalid` (0 otherwise).
    pub skipped: usize,
    /// The first few skip reasons (`line: message`), for the user.
    pub skip_examples: Vec<String>,
    /// Whether the file had a `worker` column.
    pub has_workers: bool,
}

/// One row as written to CSV (ids, not rows).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TripletRecord {
    /// Reference id.
    pub a: String,
    /// First candidate id.
    pub b: String,
    /// Second candidate id.
    pub c: String,
    /// `a` closer to `b`.
    pub q: bool,
}

/// Reads and validates a triplets CSV against `table`. Unknown ids, `q` outside {0,1}, and rows
/// naming the same item twice are errors naming file and line, or skipped and counted when
/// `skip_invalid` is set. An empty result is always an error.
pub fn read_triplets(path: &Path, table: &FeatureTable, skip_invalid: bool) -> Result<TripletSet> {
    read_triplets_from(open(path)?, path, table, skip_invalid)
}

/// [`read_triplets`] from any reader; `path` names the source in errors.
pub fn read_triplets_from<R: Read>(
    reader: R,
    path: &Path,
    table: &FeatureTable,
    skip_invalid: bool,
) -> Result<TripletSet> {
    let err = |line: u64, message: String| Error::InvalidCsv {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(reader);
    let header = rdr
        .headers()
        .map_err(|e| err(1, e.to_string()))?
        .iter()
        .map(str::trim)
        .map(str::to_owned)
        .collect::<Vec<_>>();
    if header.len() < 4 || header[..4] != ["a", "b", "c", "q"] {
        return Err(err(
            1,
            format!(
                "header must start with a,b,c,q (optionally worker,tuple_id), found `{}`",
                header.join(",")
            ),
        ));
    }
    let worker_col = header.iter().position(|h| h == "worker");
    let tuple_col = header.iter().position(|h| h == "tuple_id");
    let mut workers: HashMap<String, u32> = HashMap::new();
    let mut tuples: HashMap<TupleKey, u32> = HashMap::new();
    let mut out = TripletSet {
        triplets: Vec::new(),
        skipped: 0,
        skip_examples: Vec::new(),
        has_workers: worker_col.is_some(),
    };
    for record in rdr.records() {
        let record = record.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            err(line, e.to_string())
        })?;
        let line = record.position().map_or(0, |p| p.line());
        let parsed = (|| -> std::result::Result<Triplet, String> {
            if record.len() != header.len() {
                return Err(format!(
                    "expected {} fields, found {}",
                    header.len(),
                    record.len()
                ));
            }
            let id = |k: usize| -> std::result::Result<u32, String> {
                let s = unquote(&record[k]);
                table
                    .index_of(s)
                    .map(|i| i as u32)
                    .ok_or_else(|| format!("unknown id `{s}` (not in the features file)"))
            };
            let (a, b, c) = (id(0)?, id(1)?, id(2)?);
            if a == b || a == c || b == c {
                return Err("a triplet must name three different items".into());
            }
            let q = match record[3].trim() {
                "1" => true,
                "0" => false,
                other => return Err(format!("q must be 0 or 1, found `{other}`")),
            };
            let worker = worker_col.map(|k| {
                let n = workers.len() as u32;
                *workers.entry(unquote(&record[k]).to_owned()).or_insert(n)
            });
            let key = match tuple_col {
                Some(k) => TupleKey::Id(unquote(&record[k]).to_owned()),
                None => TupleKey::Question(a, b.min(c), b.max(c)),
            };
            let n = tuples.len() as u32;
            let tuple = *tuples.entry(key).or_insert(n);
            Ok(Triplet {
                a,
                b,
                c,
                q,
                worker,
                tuple,
            })
        })();
        match parsed {
            Ok(t) => out.triplets.push(t),
            Err(message) if skip_invalid => {
                out.skipped += 1;
                if out.skip_examples.len() < 5 {
                    out.skip_examples.push(format!("line {line}: {message}"));
                }
            }
            Err(message) => return Err(err(line, message)),
        }
    }
    if out.triplets.is_empty() {
        return Err(Error::EmptyFile {
            path: path.to_path_buf(),
        });
    }
    Ok(out)
}

/// A cell trimmed, without the `'` a spreadsheet-safe export (the platform's) puts before a
/// value starting with `=`, `+`, `-`, `@`, a tab, a carriage return or `'` so that spreadsheets
/// do not run it as a formula.
fn unquote(cell: &str) -> &str {
    let cell = cell.trim();
    match cell.strip_prefix('\'') {
        Some(rest) if rest.starts_with(['=', '+', '-', '@', '\t', '\r', '\'']) => rest.trim(),
        _ => cell,
    }
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
enum TupleKey {
    Id(String),
    Question(u32, u32, u32),
}

/// Writes triplets as `a,b,c,q`.
pub fn write_triplets(records: &[TripletRecord], path: &Path) -> Result<()> {
    let io = |e: csv::Error| Error::InvalidCsv {
        path: path.to_path_buf(),
        line: 0,
        message: e.to_string(),
    };
    let mut wtr = csv::Writer::from_writer(create(path)?);
    wtr.write_record(["a", "b", "c", "q"]).map_err(io)?;
    for r in records {
        wtr.write_record([r.a.as_str(), &r.b, &r.c, if r.q { "1" } else { "0" }])
            .map_err(io)?;
    }
    wtr.flush().map_err(|source| Error::CannotWrite {
        path: path.to_path_buf(),
        source,
    })
}

/// Labelled-group triplets as the paper built them from the Microsoft data (§5.6): `a` and `b`
/// share a style, `c` has another; then exactly half of the rows (a seeded shuffle) swap `b`
/// and `c` and get `q = 0`, so a constant predictor scores 50%.
///
/// `a` is drawn uniformly over items whose style has at least two members, so large styles
/// contribute proportionally more triplets. Deterministic for a given `seed`.
pub fn generate_labelled(labels: &[Label], n: usize, seed: u64) -> Result<Vec<TripletRecord>> {
    let mut by_style: HashMap<&str, Vec<usize>> = HashMap::new();
    for (i, l) in labels.iter().enumerate() {
        by_style.entry(&l.style).or_default().push(i);
    }
    if by_style.len() < 2 {
        return Err(Error::NotEnoughData {
            what: "labelled triplets (styles)",
            needed: 2,
            got: by_style.len(),
        });
    }
    let anchors: Vec<usize> = (0..labels.len())
        .filter(|&i| by_style[labels[i].style.as_str()].len() >= 2)
        .collect();
    if anchors.is_empty() {
        return Err(Error::NotEnoughData {
            what: "labelled triplets (items in a style with two members)",
            needed: 2,
            got: 1,
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let a = anchors[rng.random_range(0..anchors.len())];
        let same = &by_style[labels[a].style.as_str()];
        let b = loop {
            let b = same[rng.random_range(0..same.len())];
            if b != a {
                break b;
            }
        };
        let c = loop {
            let c = rng.random_range(0..labels.len());
            if labels[c].style != labels[a].style {
                break c;
            }
        };
        out.push(TripletRecord {
            a: labels[a].id.clone(),
            b: labels[b].id.clone(),
            c: labels[c].id.clone(),
            q: true,
        });
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.shuffle(&mut rng);
    for &i in &order[..n / 2] {
        let r = &mut out[i];
        std::mem::swap(&mut r.b, &mut r.c);
        r.q = false;
    }
    Ok(out)
}

/// A train/test split of labelled items by style *and* by concept: test items have a held-out
/// style and a held-out concept, training items have neither; items with exactly one of the two
/// are dropped, so no style and no concept is seen on both sides.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelSplit {
    /// Items for training.
    pub train: Vec<Label>,
    /// Items for testing.
    pub test: Vec<Label>,
    /// Items in neither.
    pub dropped: usize,
}

/// Splits `labels` holding out `test_styles` and a seeded random `concept_fraction` of concepts.
pub fn split_labels(
    labels: &[Label],
    test_styles: &[String],
    concept_fraction: f64,
    seed: u64,
) -> Result<LabelSplit> {
    if !(0.0..=1.0).contains(&concept_fraction) {
        return Err(Error::InvalidParameter {
            name: "concept_fraction",
            value: concept_fraction.to_string(),
            reason: "must be in [0, 1]",
        });
    }
    for s in test_styles {
        if !labels.iter().any(|l| &l.style == s) {
            return Err(Error::InvalidParameter {
                name: "test_styles",
                value: s.clone(),
                reason: "no item has this style",
            });
        }
    }
    let mut concepts: Vec<&str> = labels.iter().map(|l| l.concept.as_str()).collect();
    concepts.sort_unstable();
    concepts.dedup();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    concepts.shuffle(&mut rng);
    let k = (concepts.len() as f64 * concept_fraction).round() as usize;
    let held: std::collections::HashSet<&str> = concepts[..k].iter().copied().collect();
    let mut split = LabelSplit {
        train: Vec::new(),
        test: Vec::new(),
        dropped: 0,
    };
    for l in labels {
        let style_out = test_styles.contains(&l.style);
        let concept_out = held.contains(l.concept.as_str());
        match (style_out, concept_out) {
            (true, true) => split.test.push(l.clone()),
            (false, false) => split.train.push(l.clone()),
            _ => split.dropped += 1,
        }
    }
    Ok(split)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> FeatureTable {
        let ids = ["x", "y", "z", "w"].map(String::from).to_vec();
        FeatureTable::new(vec!["f".into()], ids, vec![0.0, 1.0, 2.0, 3.0]).unwrap()
    }

    fn read(text: &str, skip: bool) -> Result<TripletSet> {
        read_triplets_from(text.as_bytes(), Path::new("t.csv"), &table(), skip)
    }

    #[test]
    fn reads_and_groups_tuples() {
        let s = read("a,b,c,q\nx,y,z,1\nx,z,y,0\nx,y,w,1\n", false).unwrap();
        assert_eq!(s.triplets.len(), 3);
        assert_eq!(s.triplets[0].tuple, s.triplets[1].tuple);
        assert_ne!(s.triplets[0].tuple, s.triplets[2].tuple);
        assert!(!s.triplets[1].q);
        let s = read(
            "a,b,c,q,worker,tuple_id\nx,y,z,1,w1,t\nx,y,w,0,w2,t\n",
            false,
        )
        .unwrap();
        assert_eq!(s.triplets[0].tuple, s.triplets[1].tuple);
        assert_eq!(s.triplets[1].worker, Some(1));
    }

    #[test]
    fn spreadsheet_safe_cells_read_back() {
        let ids = ["-1.svg", "+1.svg", "'q.svg", "x"]
            .map(String::from)
            .to_vec();
        let table = FeatureTable::new(vec!["f".into()], ids, vec![0.0, 1.0, 2.0, 3.0]).unwrap();
        let text = "a,b,c,q,worker,tuple_id\n'-1.svg,'+1.svg,''q.svg,1,'@w,t\n\
                    x,'+1.svg,'-1.svg,0,@w,t\n";
        let s = read_triplets_from(text.as_bytes(), Path::new("t.csv"), &table, false).unwrap();
        assert_eq!(
            (s.triplets[0].a, s.triplets[0].b, s.triplets[0].c),
            (0, 1, 2)
        );
        assert_eq!(s.triplets[0].worker, s.triplets[1].worker, "'@w is @w");
        // A quote before anything else is part of the value.
        assert_eq!(unquote("'abc"), "'abc");
    }

    #[test]
    fn bad_rows_name_file_and_line() {
        for (text, want) in [
            (
                "a,b,c,q\nx,y,z,1\nx,y,nope,1\n",
                "t.csv:3: unknown id `nope`",
            ),
            ("a,b,c,q\nx,y,z,2\n", "t.csv:2: q must be 0 or 1"),
            ("a,b,c,q\nx,x,z,1\n", "t.csv:2: a triplet must name three"),
            ("a,b,c,q\nx,y,z\n", "t.csv:2: expected 4 fields"),
            ("a,c,b,q\nx,y,z,1\n", "t.csv:1: header must start"),
        ] {
            let e = read(text, false).unwrap_err().to_string();
            assert!(e.starts_with(want), "{e}");
        }
        assert!(matches!(
            read("a,b,c,q\n", false),
            Err(Error::EmptyFile { .. })
        ));
    }

    #[test]
    fn skip_invalid_counts() {
        let s = read("a,b,c,q\nx,y,z,1\nx,y,nope,1\nx,x,y,0\n", true).unwrap();
        assert_eq!((s.triplets.len(), s.skipped), (1, 2));
        assert!(s.skip_examples[0].starts_with("line 3:"));
    }

    fn labels() -> Vec<Label> {
        let mut v = Vec::new();
        for s in ["s1", "s2", "s3"] {
            for c in ["c1", "c2", "c3", "c4"] {
                v.push(Label {
                    id: format!("{s}/{c}"),
                    style: s.into(),
                    concept: c.into(),
                });
            }
        }
        v
    }

    #[test]
    fn generated_triplets_follow_styles_and_are_balanced() {
        let l = labels();
        let t = generate_labelled(&l, 101, 7).unwrap();
        assert_eq!(t.iter().filter(|r| !r.q).count(), 50);
        let style = |id: &str| id.split('/').next().unwrap().to_owned();
        for r in &t {
            let (close, far) = if r.q { (&r.b, &r.c) } else { (&r.c, &r.b) };
            assert_eq!(style(&r.a), style(close));
            assert_ne!(style(&r.a), style(far));
            assert_ne!(r.a, *close);
        }
        assert_eq!(t, generate_labelled(&l, 101, 7).unwrap());
        assert_ne!(t, generate_labelled(&l, 101, 8).unwrap());
    }

    #[test]
    fn split_holds_out_styles_and_concepts() {
        let l = labels();
        let s = split_labels(&l, &["s3".into()], 0.5, 1).unwrap();
        assert_eq!((s.train.len(), s.test.len(), s.dropped), (4, 2, 6));
        for t in &s.test {
            assert_eq!(t.style, "s3");
            assert!(s.train.iter().all(|r| r.concept != t.concept));
        }
        assert!(split_labels(&l, &["zz".into()], 0.5, 1).is_err());
    }
}
