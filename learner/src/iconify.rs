//! Iconify icon sets (the `icons.json` of the `@iconify-json/*` npm packages).
//!
//! Format: `prefix`, `icons` (name → `body` plus optional `width`, `height`, `left`, `top`,
//! `rotate` in quarter turns, `hFlip`, `vFlip`, `hidden`), set-level defaults for the same
//! geometry fields (width/height default to 16), `aliases` (name → `parent` plus overrides) and
//! optionally `categories` (category → icon names; the packages keep them in the sibling
//! `metadata.json`, which [`IconSet::from_path`] also reads).
//!
//! Choices: hidden icons (Iconify's deprecated ones) are skipped; an alias that changes nothing
//! is the same drawing as its parent, so it only adds its name to the parent's tags; an alias
//! that rotates, flips or resizes is a drawing of its own and becomes an item.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use serde::Deserialize;

use crate::{Error, Result};

/// Geometry and transformation fields shared by icons, aliases and set defaults.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(rename_all = "camelCase")]
struct Props {
    width: Option<f64>,
    height: Option<f64>,
    left: Option<f64>,
    top: Option<f64>,
    rotate: Option<i64>,
    h_flip: Option<bool>,
    v_flip: Option<bool>,
    hidden: Option<bool>,
}

#[derive(Debug, Deserialize)]
struct RawIcon {
    body: String,
    #[serde(flatten)]
    props: Props,
}

#[derive(Debug, Deserialize)]
struct RawAlias {
    parent: String,
    #[serde(flatten)]
    props: Props,
}

#[derive(Debug, Deserialize)]
struct RawSet {
    prefix: String,
    icons: BTreeMap<String, RawIcon>,
    #[serde(default)]
    aliases: BTreeMap<String, RawAlias>,
    #[serde(default)]
    categories: BTreeMap<String, Vec<String>>,
    #[serde(flatten)]
    defaults: Props,
}

#[derive(Debug, Default, Deserialize)]
struct RawMetadata {
    #[serde(default)]
    categories: BTreeMap<String, Vec<String>>,
}

/// One drawable icon of a set, as a standalone SVG.
#[derive(Debug, Clone, PartialEq)]
pub struct Icon {
    /// `prefix:name`.
    pub id: String,
    /// Words of the name, names of plain aliases, and the categories the icon is listed in.
    pub tags: Vec<String>,
    /// A standalone SVG document.
    pub svg: String,
}

/// A parsed icon set.
#[derive(Debug, Clone)]
pub struct IconSet {
    /// The set's prefix.
    pub prefix: String,
    /// Its drawable icons, in name order.
    pub icons: Vec<Icon>,
}

/// Resolved geometry of one drawing.
#[derive(Debug, Clone, Copy)]
struct Geometry {
    left: f64,
    top: f64,
    width: f64,
    height: f64,
    rotate: i64,
    h_flip: bool,
    v_flip: bool,
}

impl Geometry {
    fn apply(mut self, p: &Props) -> Geometry {
        self.left = p.left.unwrap_or(self.left);
        self.top = p.top.unwrap_or(self.top);
        self.width = p.width.unwrap_or(self.width);
        self.height = p.height.unwrap_or(self.height);
        self
    }

    /// Aliases compose transformations with their parent's (Iconify's `mergeIconData`).
    fn compose(mut self, p: &Props) -> Geometry {
        self = self.apply(p);
        self.rotate = (self.rotate + p.rotate.unwrap_or(0)).rem_euclid(4);
        self.h_flip ^= p.h_flip.unwrap_or(false);
        self.v_flip ^= p.v_flip.unwrap_or(false);
        self
    }
}

impl IconSet {
    /// Reads `icons.json`, plus categories from a sibling `metadata.json` when present.
    pub fn from_path(path: &Path) -> Result<Self> {
        let bytes = crate::input::read_limited(path, crate::render::MAX_SVG_BYTES * 10)?;
        let mut set = Self::parse(&bytes)?;
        let metadata = path.with_file_name("metadata.json");
        if metadata.is_file() {
            let raw = crate::input::read_limited(&metadata, crate::render::MAX_SVG_BYTES)?;
            let meta: RawMetadata = serde_json::from_slice(&raw)
                .map_err(|e| Error::InvalidIconify(format!("{}: {e}", metadata.display())))?;
            set.add_categories(&meta.categories);
        }
        Ok(set)
    }

    /// Parses the JSON text of an icon set.
    pub fn parse(json: &[u8]) -> Result<Self> {
        let raw: RawSet =
            serde_json::from_slice(json).map_err(|e| Error::InvalidIconify(e.to_string()))?;
        if raw.prefix.is_empty() {
            return Err(Error::InvalidIconify("empty prefix".into()));
        }
        let base = Geometry {
            left: raw.defaults.left.unwrap_or(0.0),
            top: raw.defaults.top.unwrap_or(0.0),
            width: raw.defaults.width.unwrap_or(16.0),
            height: raw.defaults.height.unwrap_or(16.0),
            rotate: 0,
            h_flip: false,
            v_flip: false,
        };
        let mut icons: BTreeMap<String, Icon> = BTreeMap::new();
        for (name, icon) in &raw.icons {
            if icon.props.hidden == Some(true) {
                continue;
            }
            let geometry = base.compose(&icon.props);
            icons.insert(
                name.clone(),
                make_icon(&raw.prefix, name, &icon.body, geometry),
            );
        }
        for (name, alias) in &raw.aliases {
            if alias.props.hidden == Some(true) {
                continue;
            }
            // Follow the chain of parents (bounded, so a cycle is an error, not a hang).
            let mut chain = vec![&alias.props];
            let mut parent = &alias.parent;
            let mut resolved = None;
            for _ in 0..32 {
                if let Some(icon) = raw.icons.get(parent) {
                    resolved = Some(icon);
                    break;
                }
                match raw.aliases.get(parent) {
                    Some(next) => {
                        chain.push(&next.props);
                        parent = &next.parent;
                    }
                    None => break,
                }
            }
            let Some(icon) = resolved else {
                return Err(Error::InvalidIconify(format!(
                    "alias '{name}' has no icon among its parents"
                )));
            };
            if icon.props.hidden == Some(true) {
                continue;
            }
            let changes_drawing = chain.iter().any(|p| {
                p.width.is_some()
                    || p.height.is_some()
                    || p.left.is_some()
                    || p.top.is_some()
                    || p.rotate.unwrap_or(0).rem_euclid(4) != 0
                    || p.h_flip == Some(true)
                    || p.v_flip == Some(true)
            });
            if changes_drawing {
                let mut geometry = base.compose(&icon.props);
                for p in chain.iter().rev() {
                    geometry = geometry.compose(p);
                }
                icons.insert(
                    name.clone(),
                    make_icon(&raw.prefix, name, &icon.body, geometry),
                );
            } else if let Some(target) = icons.get_mut(parent) {
                push_unique(&mut target.tags, name_words(name));
            }
        }
        let mut set = IconSet {
            prefix: raw.prefix,
            icons: icons.into_values().collect(),
        };
        set.add_categories(&raw.categories);
        Ok(set)
    }

    fn add_categories(&mut self, categories: &BTreeMap<String, Vec<String>>) {
        let mut by_icon: HashMap<&str, Vec<&str>> = HashMap::new();
        for (category, names) in categories {
            for n in names {
                by_icon.entry(n.as_str()).or_default().push(category);
            }
        }
        let prefix_len = self.prefix.len() + 1;
        for icon in &mut self.icons {
            if let Some(cats) = by_icon.get(&icon.id[prefix_len..]) {
                push_unique(&mut icon.tags, cats.iter().map(|c| c.to_lowercase()));
            }
        }
    }
}

fn push_unique(tags: &mut Vec<String>, new: impl IntoIterator<Item = String>) {
    for t in new {
        if !tags.contains(&t) {
            tags.push(t);
        }
    }
}

fn name_words(name: &str) -> Vec<String> {
    name.split(['-', '_'])
        .filter(|w| !w.is_empty())
        .map(str::to_lowercase)
        .collect()
}

fn make_icon(prefix: &str, name: &str, body: &str, g: Geometry) -> Icon {
    let (cx, cy) = (g.left + g.width / 2.0, g.top + g.height / 2.0);
    let mut transforms = Vec::new();
    if g.h_flip {
        transforms.push(format!(
            "translate({} 0) scale(-1 1)",
            2.0 * g.left + g.width
        ));
    }
    if g.v_flip {
        transforms.push(format!(
            "translate(0 {}) scale(1 -1)",
            2.0 * g.top + g.height
        ));
    }
    // SVG applies the leftmost transform last, so rotation goes first in the list.
    if g.rotate != 0 {
        transforms.insert(0, format!("rotate({} {cx} {cy})", 90 * g.rotate));
    }
    let (vw, vh) = if g.rotate % 2 == 1 {
        (g.height, g.width)
    } else {
        (g.width, g.height)
    };
    let (vl, vt) = (cx - vw / 2.0, cy - vh / 2.0);
    let inner = if transforms.is_empty() {
        body.to_string()
    } else {
        format!(r#"<g transform="{}">{body}</g>"#, transforms.join(" "))
    };
    Icon {
        id: format!("{prefix}:{name}"),
        tags: name_words(name),
        svg: format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" viewBox="{vl} {vt} {vw} {vh}" width="{vw}" height="{vh}">{inner}</svg>"#
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SET: &str = r##"{
        "prefix": "demo", "width": 24, "height": 24,
        "icons": {
            "arrow-left": {"body": "<path d='M0 12h12'/>"},
            "wide": {"body": "<rect width='48' height='24' fill='red'/>", "width": 48},
            "old": {"body": "<path/>", "hidden": true}
        },
        "aliases": {
            "back": {"parent": "arrow-left"},
            "arrow-right": {"parent": "arrow-left", "hFlip": true},
            "arrow-up": {"parent": "arrow-right", "rotate": 1},
            "ghost": {"parent": "old"}
        },
        "categories": {"Arrows": ["arrow-left", "arrow-right"]}
    }"##;

    #[test]
    fn icons_aliases_hidden_and_categories() {
        let set = IconSet::parse(SET.as_bytes()).unwrap();
        let ids: Vec<&str> = set.icons.iter().map(|i| i.id.as_str()).collect();
        assert_eq!(
            ids,
            [
                "demo:arrow-left",
                "demo:arrow-right",
                "demo:arrow-up",
                "demo:wide"
            ]
        );
        let left = &set.icons[0];
        assert_eq!(left.tags, ["arrow", "left", "back", "arrows"]);
        assert!(left.svg.contains(r#"viewBox="0 0 24 24""#));
        assert!(set.icons[1].svg.contains("scale(-1 1)"));
        assert!(
            set.icons[2].svg.contains("rotate(90 12 12)")
                && set.icons[2].svg.contains("scale(-1 1)")
        );
        assert!(set.icons[3].svg.contains(r#"viewBox="0 0 48 24""#));
    }

    #[test]
    fn flipped_alias_renders_mirrored() {
        let json = r##"{"prefix":"t","width":10,"height":10,
            "icons":{"half":{"body":"<rect width='5' height='10' fill='black'/>"}},
            "aliases":{"mirrored":{"parent":"half","hFlip":true},"turned":{"parent":"half","rotate":1}}}"##;
        let set = IconSet::parse(json.as_bytes()).unwrap();
        let render = |i: usize| crate::render::render_svg(set.icons[i].svg.as_bytes()).unwrap();
        let (half, mirrored, turned) = (render(0), render(1), render(2));
        assert_eq!(half.get_pixel(100, 200).0, [0; 3]);
        assert_eq!(half.get_pixel(300, 200).0, [255; 3]);
        assert_eq!(mirrored.get_pixel(100, 200).0, [255; 3]);
        assert_eq!(mirrored.get_pixel(300, 200).0, [0; 3]);
        // A quarter turn clockwise puts the left half on top.
        assert_eq!(turned.get_pixel(200, 100).0, [0; 3]);
        assert_eq!(turned.get_pixel(200, 300).0, [255; 3]);
    }

    #[test]
    fn malformed_sets_are_errors() {
        assert!(IconSet::parse(b"{").is_err());
        assert!(IconSet::parse(br#"{"prefix":"x"}"#).is_err());
        assert!(IconSet::parse(br#"{"prefix":"","icons":{}}"#).is_err());
        let cycle =
            br#"{"prefix":"x","icons":{},"aliases":{"a":{"parent":"b"},"b":{"parent":"a"}}}"#;
        assert!(
            matches!(IconSet::parse(cycle), Err(Error::InvalidIconify(m)) if m.contains("'a'"))
        );
    }
}
