//! Finding the clip-art items a user points us at: folders of `.svg` files (recursively), raster
//! images (`.png`, `.jpg`, `.jpeg`), and Iconify icon-set JSON files.
//!
//! Every item gets a stable id — its path relative to the folder it was found under (with `/`
//! separators), the file name for a file given directly, or `prefix:name` for Iconify — and tags:
//! Iconify name words and categories, or the keywords of a sidecar CSV (`file,keywords`, keywords
//! separated by `;` or `,`, as in the style data's `labels.csv`).
//!
//! Discovery never stops at a bad item: unreadable files, malformed icon sets and duplicate ids
//! are returned as [`InputError`]s beside the items that are fine.

use std::collections::{HashMap, HashSet};
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

use image::{RgbImage, RgbaImage};

use crate::iconify::IconSet;
use crate::render;
use crate::{Error, Result};

/// Where an item's drawing comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// An SVG file.
    SvgFile(PathBuf),
    /// A PNG/JPEG/TIFF file.
    RasterFile(PathBuf),
    /// SVG text made from an Iconify icon set.
    SvgText(String),
}

/// One piece of clip art.
#[derive(Debug, Clone, PartialEq)]
pub struct Item {
    /// Stable id: relative path, file name, or `prefix:name`.
    pub id: String,
    /// Keywords describing it.
    pub tags: Vec<String>,
    /// Its drawing.
    pub source: Source,
}

impl Item {
    /// Reads and renders the item onto the 400x400 white canvas.
    pub fn render(&self) -> Result<RgbImage> {
        match &self.source {
            Source::SvgFile(path) => {
                render::render_svg(&read_limited(path, render::MAX_SVG_BYTES)?)
            }
            Source::RasterFile(path) => {
                render::render_raster(&read_limited(path, render::MAX_RASTER_BYTES)?)
            }
            Source::SvgText(svg) => render::render_svg(svg.as_bytes()),
        }
    }

    /// For a raster item, its 400x400 rendering with the transparency kept
    /// ([`render::render_raster_rgba`]); `None` for a drawing, whose vector source keeps it.
    pub fn render_cutout(&self) -> Result<Option<RgbaImage>> {
        match &self.source {
            Source::RasterFile(path) => Ok(Some(render::render_raster_rgba(&read_limited(
                path,
                render::MAX_RASTER_BYTES,
            )?)?)),
            Source::SvgFile(_) | Source::SvgText(_) => Ok(None),
        }
    }
}

/// A problem with one input, reported beside the items that are fine.
#[derive(Debug)]
pub struct InputError {
    /// The file (and, for Iconify, the icon) concerned.
    pub location: String,
    /// What went wrong.
    pub error: Error,
}

/// The result of [`discover`].
#[derive(Debug, Default)]
pub struct Discovery {
    /// Items in a stable order (inputs in the given order; files sorted by path within a folder).
    pub items: Vec<Item>,
    /// Inputs that could not be used.
    pub errors: Vec<InputError>,
}

/// What kind of file a path names, by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Svg,
    Raster,
    Iconify,
}

fn kind_of(path: &Path) -> Option<Kind> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "svg" => Some(Kind::Svg),
        "png" | "jpg" | "jpeg" | "tif" | "tiff" => Some(Kind::Raster),
        "json" => Some(Kind::Iconify),
        _ => None,
    }
}

/// Finds the items under `inputs`. Folders are searched recursively for `.svg`, `.png`, `.jpg`
/// and `.jpeg` files (JSON inside folders is ignored: name Iconify files explicitly). `sidecar`,
/// when given, supplies tags for file items by their id.
pub fn discover(inputs: &[PathBuf], sidecar: Option<&Path>) -> Result<Discovery> {
    let tags = match sidecar {
        Some(path) => read_sidecar(path)?,
        None => HashMap::new(),
    };
    let mut found = Discovery::default();
    for input in inputs {
        if input.is_dir() {
            let mut files: Vec<PathBuf> = Vec::new();
            for entry in walkdir::WalkDir::new(input).follow_links(false) {
                match entry {
                    Ok(e) if e.file_type().is_file() => {
                        if matches!(kind_of(e.path()), Some(Kind::Svg | Kind::Raster)) {
                            files.push(e.into_path());
                        }
                    }
                    Ok(_) => {}
                    Err(e) => found.errors.push(InputError {
                        location: e.path().unwrap_or(input).display().to_string(),
                        error: Error::Io {
                            path: e.path().unwrap_or(input).to_path_buf(),
                            source: e
                                .into_io_error()
                                .unwrap_or_else(|| std::io::Error::other("filesystem loop")),
                        },
                    }),
                }
            }
            files.sort();
            for path in files {
                let id = relative_id(input, &path);
                found.items.push(file_item(id, path, &tags));
            }
        } else {
            match kind_of(input) {
                Some(Kind::Iconify) => match IconSet::from_path(input) {
                    Ok(set) => found.items.extend(set.icons.into_iter().map(|icon| Item {
                        id: icon.id,
                        tags: icon.tags,
                        source: Source::SvgText(icon.svg),
                    })),
                    Err(error) => found.errors.push(InputError {
                        location: input.display().to_string(),
                        error,
                    }),
                },
                Some(_) if input.is_file() => {
                    let id = input
                        .file_name()
                        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
                    found.items.push(file_item(id, input.clone(), &tags));
                }
                Some(_) => found.errors.push(InputError {
                    location: input.display().to_string(),
                    error: Error::Io {
                        path: input.clone(),
                        source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
                    },
                }),
                None => found.errors.push(InputError {
                    location: input.display().to_string(),
                    error: Error::UnsupportedInput(input.clone()),
                }),
            }
        }
    }
    // Ids must be unique: the first occurrence wins, later ones are reported.
    let mut seen = HashSet::new();
    let mut unique = Vec::with_capacity(found.items.len());
    for item in found.items {
        if seen.insert(item.id.clone()) {
            unique.push(item);
        } else {
            found.errors.push(InputError {
                location: describe(&item.source),
                error: Error::DuplicateId(item.id),
            });
        }
    }
    found.items = unique;
    Ok(found)
}

fn describe(source: &Source) -> String {
    match source {
        Source::SvgFile(p) | Source::RasterFile(p) => p.display().to_string(),
        Source::SvgText(_) => "Iconify icon".into(),
    }
}

fn file_item(id: String, path: PathBuf, tags: &HashMap<String, Vec<String>>) -> Item {
    let source = match kind_of(&path) {
        Some(Kind::Svg) => Source::SvgFile(path),
        _ => Source::RasterFile(path),
    };
    let tags = tags.get(&id).cloned().unwrap_or_default();
    Item { id, tags, source }
}

fn relative_id(root: &Path, path: &Path) -> String {
    let rel = path.strip_prefix(root).unwrap_or(path);
    rel.components()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}

/// Reads a sidecar CSV with (at least) the columns `file` and `keywords`.
pub fn read_sidecar(path: &Path) -> Result<HashMap<String, Vec<String>>> {
    let bytes = read_limited(path, render::MAX_SVG_BYTES * 10)?;
    let mut reader = csv::ReaderBuilder::new()
        .flexible(false)
        .from_reader(bytes.as_slice());
    let csv_error = |line: u64, message: String| Error::InvalidCsv {
        path: path.to_path_buf(),
        line,
        message,
    };
    let headers = reader
        .headers()
        .map_err(|e| csv_error(1, e.to_string()))?
        .clone();
    let column = |name: &str| {
        headers
            .iter()
            .position(|h| h.trim() == name)
            .ok_or_else(|| csv_error(1, format!("no '{name}' column")))
    };
    let (file_col, keywords_col) = (column("file")?, column("keywords")?);
    let mut tags = HashMap::new();
    for (row, record) in reader.records().enumerate() {
        let line = row as u64 + 2;
        let record = record.map_err(|e| csv_error(line, e.to_string()))?;
        let file = record.get(file_col).unwrap_or_default().trim().to_string();
        if file.is_empty() {
            return Err(csv_error(line, "empty 'file'".into()));
        }
        let keywords = record
            .get(keywords_col)
            .unwrap_or_default()
            .split([';', ','])
            .map(|k| k.trim().to_string())
            .filter(|k| !k.is_empty())
            .collect();
        tags.insert(file, keywords);
    }
    Ok(tags)
}

/// Reads a whole file, refusing files over `limit` bytes before reading them.
pub fn read_limited(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = File::open(path).map_err(io)?;
    let size = file.metadata().map_err(io)?.len();
    if size > limit {
        return Err(Error::FileTooLarge { size, limit });
    }
    let mut bytes = Vec::with_capacity(size as usize);
    // `take` guards against a file that grows while we read it.
    file.take(limit + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(Error::FileTooLarge {
            size: bytes.len() as u64,
            limit,
        });
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    #[test]
    fn folders_files_iconify_and_sidecar() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path();
        fs::create_dir_all(root.join("art/sub")).unwrap();
        fs::write(root.join("art/b.svg"), "<svg/>").unwrap();
        fs::write(root.join("art/sub/a.svg"), "<svg/>").unwrap();
        fs::write(root.join("art/sub/c.PNG"), "x").unwrap();
        fs::write(root.join("art/notes.txt"), "x").unwrap();
        fs::write(
            root.join("set.json"),
            r#"{"prefix":"p","icons":{"dog-face":{"body":""}}}"#,
        )
        .unwrap();
        fs::write(
            root.join("tags.csv"),
            "file,keywords\nsub/a.svg,cat;animal\n",
        )
        .unwrap();
        let found = discover(
            &[
                root.join("art"),
                root.join("set.json"),
                root.join("missing.svg"),
                root.join("x.doc"),
            ],
            Some(&root.join("tags.csv")),
        )
        .unwrap();
        let ids: Vec<&str> = found.items.iter().map(|i| i.id.as_str()).collect();
        assert_eq!(ids, ["b.svg", "sub/a.svg", "sub/c.PNG", "p:dog-face"]);
        assert_eq!(found.items[1].tags, ["cat", "animal"]);
        assert_eq!(found.items[3].tags, ["dog", "face"]);
        assert!(matches!(found.items[2].source, Source::RasterFile(_)));
        assert_eq!(found.errors.len(), 2);
        assert!(matches!(found.errors[1].error, Error::UnsupportedInput(_)));
    }

    #[test]
    fn duplicate_ids_are_reported_not_merged() {
        let dir = tempfile::tempdir().unwrap();
        fs::create_dir_all(dir.path().join("a")).unwrap();
        fs::create_dir_all(dir.path().join("b")).unwrap();
        fs::write(dir.path().join("a/x.svg"), "<svg/>").unwrap();
        fs::write(dir.path().join("b/x.svg"), "<svg/>").unwrap();
        let found = discover(&[dir.path().join("a"), dir.path().join("b")], None).unwrap();
        assert_eq!(found.items.len(), 1);
        assert!(matches!(&found.errors[0].error, Error::DuplicateId(id) if id == "x.svg"));
    }

    #[test]
    fn sidecar_errors_name_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        fs::write(&p, "file,keywords\na.svg,x\n,y\n").unwrap();
        let err = read_sidecar(&p).unwrap_err().to_string();
        assert!(err.ends_with("t.csv:3: empty 'file'"), "{err}");
        fs::write(&p, "name,words\n").unwrap();
        assert!(
            read_sidecar(&p)
                .unwrap_err()
                .to_string()
                .contains("no 'file' column")
        );
    }

    #[test]
    fn read_limited_refuses_large_files() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.svg");
        fs::write(&p, vec![b'x'; 101]).unwrap();
        assert!(matches!(
            read_limited(&p, 100),
            Err(Error::FileTooLarge {
                size: 101,
                limit: 100
            })
        ));
        assert_eq!(read_limited(&p, 101).unwrap().len(), 101);
    }
}
