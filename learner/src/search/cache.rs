//! A search index saved in a folder, so a library is indexed once and queried many times, and
//! the fingerprint that tells whether it still matches its sources.
//!
//! The folder holds `keywords/` (tantivy's own files, memory-mapped when opened) and
//! `style.bin`: the 8 bytes `SKSEARCH`, a little-endian `u32` format version, a `u64` header
//! length, a JSON header (fingerprint, ids, projection, clustering summary), then the rows as
//! little-endian `f32` (`items × stride`), each item's first-level cluster as `u16` and its
//! distance to that cluster's centre as `f32`. It is written to a temporary file and renamed
//! into place.
//!
//! The fingerprint holds the SHA-256 of the features file, the labels file and the model, with
//! their sizes and modification times, and the build parameters: any change makes the index
//! stale. Hashing a 200,000-item features file takes a moment, so files whose size and
//! modification time are unchanged keep their stored hash.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::time::UNIX_EPOCH;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::diversity::{Diversity, DiversityInfo};
use super::index::{MatrixParts, StyleMatrix};
use super::keywords::KeywordIndex;
use super::{BuildInfo, SearchIndex, SearchParams, row_map};
use crate::{Error, Result};

const MAGIC: &[u8; 8] = b"SKSEARCH";
/// Version of `style.bin`.
pub const FORMAT: u32 = 1;
/// The file of the style part inside an index folder.
pub const STYLE_FILE: &str = "style.bin";
/// The folder of the keyword part inside an index folder.
pub const KEYWORDS_DIR: &str = "keywords";

/// A source file as it was when the index was built.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileStamp {
    /// Size in bytes.
    pub len: u64,
    /// Modification time, nanoseconds since the Unix epoch (0 when unknown).
    pub modified_ns: u64,
    /// SHA-256 of the contents (hex).
    pub sha256: String,
}

impl FileStamp {
    /// Size and modification time of `path`, and its hash — taken from `known` without reading
    /// the file when size and time match it.
    pub fn of(path: &Path, known: Option<&FileStamp>) -> Result<Self> {
        let io = |source| Error::Io {
            path: path.to_path_buf(),
            source,
        };
        let meta = std::fs::metadata(path).map_err(io)?;
        let modified_ns = meta
            .modified()
            .ok()
            .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos() as u64);
        if let Some(k) = known
            && k.len == meta.len()
            && k.modified_ns == modified_ns
            && modified_ns != 0
        {
            return Ok(k.clone());
        }
        let mut hasher = Sha256::new();
        let mut file = File::open(path).map_err(io)?;
        let mut buf = vec![0u8; 1 << 20];
        loop {
            let n = file.read(&mut buf).map_err(io)?;
            if n == 0 {
                break;
            }
            hasher.update(&buf[..n]);
        }
        Ok(Self {
            len: meta.len(),
            modified_ns,
            sha256: hex(&hasher.finalize()),
        })
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Everything an index was built from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fingerprint {
    /// The features file.
    pub features: FileStamp,
    /// The labels/tags file, if any.
    pub labels: Option<FileStamp>,
    /// The model, if any (none: uniform weights).
    pub model: Option<FileStamp>,
    /// The build parameters.
    pub params: SearchParams,
}

/// The files an index is built from.
#[derive(Debug, Clone, Copy)]
pub struct Sources<'a> {
    /// Features CSV.
    pub features: &'a Path,
    /// Labels/tags CSV.
    pub labels: Option<&'a Path>,
    /// `model.json`.
    pub model: Option<&'a Path>,
}

impl Fingerprint {
    /// The fingerprint of `sources` now, reusing the hashes in `known` for files whose size
    /// and modification time it records.
    pub fn of(sources: Sources<'_>, params: &SearchParams, known: Option<&Self>) -> Result<Self> {
        let stamp = |path: Option<&Path>, known: Option<&FileStamp>| {
            path.map(|p| FileStamp::of(p, known)).transpose()
        };
        Ok(Self {
            features: FileStamp::of(sources.features, known.map(|k| &k.features))?,
            labels: stamp(sources.labels, known.and_then(|k| k.labels.as_ref()))?,
            model: stamp(sources.model, known.and_then(|k| k.model.as_ref()))?,
            params: *params,
        })
    }

    /// Why an index with fingerprint `self` does not fit `current`, or `None` when it does.
    pub fn staleness(&self, current: &Self) -> Option<&'static str> {
        if self.features.sha256 != current.features.sha256 {
            Some("the features changed")
        } else if self.labels.as_ref().map(|s| &s.sha256)
            != current.labels.as_ref().map(|s| &s.sha256)
        {
            Some("the labels changed")
        } else if self.model.as_ref().map(|s| &s.sha256)
            != current.model.as_ref().map(|s| &s.sha256)
        {
            Some("the model changed")
        } else if self.params != current.params {
            Some("the clustering parameters changed")
        } else {
            None
        }
    }
}

/// The JSON header of `style.bin`.
#[derive(Serialize, Deserialize)]
struct Header {
    fingerprint: Option<Fingerprint>,
    ids: Vec<String>,
    feature_names: Vec<String>,
    uniform: bool,
    matrix: MatrixParts,
    stride: usize,
    leaf_top: Vec<u16>,
    diversity: DiversityInfo,
    build: BuildInfo,
}

impl SearchIndex {
    /// Builds an index into the folder `dir` (replacing whatever index is there). Call
    /// [`SearchIndex::save`] afterwards to write the style part.
    pub fn build_in(
        dir: &Path,
        table: &crate::table::FeatureTable,
        texts: Vec<super::ItemText>,
        weighting: &super::Weighting,
        params: &SearchParams,
        progress: &mut dyn FnMut(super::BuildProgress),
    ) -> Result<Self> {
        let keywords = dir.join(KEYWORDS_DIR);
        if keywords.exists() {
            std::fs::remove_dir_all(&keywords).map_err(|source| Error::CannotWrite {
                path: keywords.clone(),
                source,
            })?;
        }
        Self::build(table, texts, weighting, params, Some(&keywords), progress)
    }

    /// Writes `style.bin` into the folder the index was built in by [`SearchIndex::build_in`],
    /// with the fingerprint of its sources.
    pub fn save(&self, dir: &Path, fingerprint: Option<&Fingerprint>) -> Result<()> {
        if self.keywords_dir.as_deref() != Some(dir.join(KEYWORDS_DIR).as_path()) {
            return Err(Error::InvalidParameter {
                name: "dir",
                value: dir.display().to_string(),
                reason: "an index is saved into the folder it was built in (build_in)",
            });
        }
        let path = dir.join(STYLE_FILE);
        let temp = dir.join(format!(".{STYLE_FILE}.partial"));
        let cannot = |source| Error::CannotWrite {
            path: temp.clone(),
            source,
        };
        let header = Header {
            fingerprint: fingerprint.cloned(),
            ids: self.ids.clone(),
            feature_names: self.feature_names.clone(),
            uniform: self.uniform,
            matrix: self.matrix.parts(),
            stride: self.matrix.stride(),
            leaf_top: self.diversity.leaf_top.clone(),
            diversity: self.diversity.info.clone(),
            build: self.build.clone(),
        };
        let json = serde_json::to_vec(&header).map_err(|source| Error::Json {
            path: path.clone(),
            source,
        })?;
        let mut w = BufWriter::new(File::create(&temp).map_err(cannot)?);
        let mut put = |bytes: &[u8]| w.write_all(bytes);
        put(MAGIC).map_err(cannot)?;
        put(&FORMAT.to_le_bytes()).map_err(cannot)?;
        put(&(json.len() as u64).to_le_bytes()).map_err(cannot)?;
        put(&json).map_err(cannot)?;
        for v in self.matrix.data() {
            put(&v.to_le_bytes()).map_err(cannot)?;
        }
        for v in &self.diversity.leaf {
            put(&v.to_le_bytes()).map_err(cannot)?;
        }
        for v in &self.diversity.centre_distance {
            put(&v.to_le_bytes()).map_err(cannot)?;
        }
        let file = w.into_inner().map_err(|e| cannot(e.into_error()))?;
        file.sync_all().map_err(cannot)?;
        std::fs::rename(&temp, &path).map_err(|source| Error::CannotWrite { path, source })
    }

    /// Opens an index folder written by [`SearchIndex::save`]; also returns the fingerprint
    /// it was saved with.
    pub fn load(dir: &Path) -> Result<(Self, Option<Fingerprint>)> {
        let path = dir.join(STYLE_FILE);
        let invalid = |reason: String| Error::InvalidIndex {
            path: path.clone(),
            reason,
        };
        let file = File::open(&path).map_err(|source| Error::Io {
            path: path.clone(),
            source,
        })?;
        let len = file.metadata().map(|m| m.len()).unwrap_or(0);
        let mut r = BufReader::with_capacity(1 << 20, file);
        let mut fixed = [0u8; 20];
        r.read_exact(&mut fixed)
            .map_err(|_| invalid("shorter than its header".into()))?;
        if &fixed[..8] != MAGIC {
            return Err(invalid("it does not start with SKSEARCH".into()));
        }
        let format = u32::from_le_bytes(fixed[8..12].try_into().expect("4 bytes"));
        if format != FORMAT {
            return Err(invalid(format!(
                "format {format}, this version reads {FORMAT}"
            )));
        }
        let header_len = u64::from_le_bytes(fixed[12..20].try_into().expect("8 bytes"));
        if header_len > len {
            return Err(invalid("truncated header".into()));
        }
        let mut json = vec![0u8; header_len as usize];
        r.read_exact(&mut json)
            .map_err(|_| invalid("truncated header".into()))?;
        let h: Header =
            serde_json::from_slice(&json).map_err(|e| invalid(format!("header: {e}")))?;
        let n = h.ids.len();
        let body = 20 + header_len + (n * h.stride) as u64 * 4 + n as u64 * 6;
        if body != len {
            return Err(invalid(format!(
                "{len} bytes where {n} items need {body}: truncated or damaged"
            )));
        }
        let data = read_f32(&mut r, n * h.stride).map_err(|e| invalid(e.to_string()))?;
        let mut leaf = vec![0u16; n];
        let mut buf = vec![0u8; n * 2];
        r.read_exact(&mut buf).map_err(|e| invalid(e.to_string()))?;
        for (v, b) in leaf.iter_mut().zip(buf.chunks_exact(2)) {
            *v = u16::from_le_bytes([b[0], b[1]]);
        }
        let centre_distance = read_f32(&mut r, n).map_err(|e| invalid(e.to_string()))?;
        if leaf.iter().any(|&l| l as usize >= h.leaf_top.len()) {
            return Err(invalid("cluster numbers out of range".into()));
        }
        let matrix = StyleMatrix::from_parts(h.matrix, data)?;
        if matrix.stride() != h.stride || matrix.len() != n {
            return Err(invalid("row layout does not match the header".into()));
        }
        let keywords_dir = dir.join(KEYWORDS_DIR);
        let keywords = KeywordIndex::open(&keywords_dir)?;
        if keywords.len() != n {
            return Err(invalid(format!(
                "the keyword index has {} items, the style index {n}",
                keywords.len()
            )));
        }
        let index = Self {
            rows: row_map(&h.ids),
            ids: h.ids,
            feature_names: h.feature_names,
            uniform: h.uniform,
            matrix,
            diversity: Diversity::from_parts(leaf, h.leaf_top, centre_distance, h.diversity),
            keywords,
            keywords_dir: Some(keywords_dir),
            build: h.build,
        };
        Ok((index, h.fingerprint))
    }
}

fn read_f32(r: &mut impl Read, count: usize) -> std::io::Result<Vec<f32>> {
    let mut out = Vec::with_capacity(count);
    let mut buf = vec![0u8; 1 << 16];
    let mut left = count * 4;
    while left > 0 {
        let chunk = left.min(buf.len());
        r.read_exact(&mut buf[..chunk])?;
        out.extend(
            buf[..chunk]
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        );
        left -= chunk;
    }
    Ok(out)
}

/// The default index folder of a features file: `features.csv` → `features.csv.search`.
pub fn default_dir(features: &Path) -> PathBuf {
    let mut name = features.file_name().unwrap_or_default().to_os_string();
    name.push(".search");
    features.with_file_name(name)
}
