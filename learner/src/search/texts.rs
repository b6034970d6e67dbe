//! The words of each item for keyword search (§5.7.3), from its id and an optional labels or
//! tags CSV such as the style data's `labels.csv`.

use std::collections::HashMap;
use std::path::Path;

use super::keywords::ItemText;
use crate::table::open;
use crate::{Error, Result};

/// Reads a CSV with an item column `file` (or `id`) and any of:
/// * `name`: the item's name (default: the id's words without the file extension);
/// * `keywords`, `tags`: words separated by `;` or `,`;
/// * `category`: a category path such as `animals-nature/animal-mammal`; without it, `group`
///   (and `subgroup` below it) as in the style data's `labels.csv`.
///
/// Other columns are ignored. Returns the text of each listed item by id.
pub fn read_item_texts(path: &Path) -> Result<HashMap<String, ItemText>> {
    read_item_texts_from(open(path)?, path)
}

/// [`read_item_texts`] from any reader; `path` names the source in errors.
pub fn read_item_texts_from<R: std::io::Read>(
    reader: R,
    path: &Path,
) -> Result<HashMap<String, ItemText>> {
    let error = |line: u64, message: String| Error::InvalidCsv {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .flexible(false)
        .from_reader(reader);
    let header = rdr.headers().map_err(|e| error(1, e.to_string()))?.clone();
    let col = |name: &str| header.iter().position(|h| h.trim() == name);
    let id_col = col("file")
        .or_else(|| col("id"))
        .ok_or_else(|| error(1, "no `file` (or `id`) column".into()))?;
    let (name_col, keywords_col, tags_col) = (col("name"), col("keywords"), col("tags"));
    let (category_col, group_col, subgroup_col) = (col("category"), col("group"), col("subgroup"));
    let mut out = HashMap::new();
    for record in rdr.records() {
        let record = record.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            error(line, e.to_string())
        })?;
        let line = record.position().map_or(0, |p| p.line());
        let field = |c: Option<usize>| c.and_then(|c| record.get(c)).unwrap_or("").trim();
        let id = field(Some(id_col));
        if id.is_empty() {
            return Err(error(line, "empty item id".into()));
        }
        let words = |c| {
            field(c)
                .split([';', ','])
                .map(str::trim)
                .filter(|w| !w.is_empty())
                .map(String::from)
                .collect::<Vec<_>>()
        };
        let category = match field(category_col) {
            "" => match (field(group_col), field(subgroup_col)) {
                ("", _) => None,
                (g, "") => Some(g.to_string()),
                (g, s) => Some(format!("{g}/{s}")),
            },
            c => Some(c.to_string()),
        };
        let name = match field(name_col) {
            "" => ItemText::from_id(id).name,
            n => n.to_string(),
        };
        let text = ItemText {
            name,
            tags: words(tags_col),
            keywords: words(keywords_col),
            category,
        };
        if out.insert(id.to_string(), text).is_some() {
            return Err(error(line, format!("duplicate item `{id}`")));
        }
    }
    Ok(out)
}

/// The text of every id: from `labels` where listed, otherwise from the id alone.
pub fn texts_for(ids: &[String], labels: Option<&HashMap<String, ItemText>>) -> Vec<ItemText> {
    ids.iter()
        .map(|id| {
            labels
                .and_then(|l| l.get(id))
                .cloned()
                .unwrap_or_else(|| ItemText::from_id(id))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_labels_csv_columns() {
        let text = "file,style,concept,keywords,group,subgroup\n\
                    noto/dog-face.svg,noto,dog-face,adorbs;dog;pet,animals-nature,animal-mammal\n\
                    noto/apple.svg,noto,apple,fruit,food-drink,\n";
        let t = read_item_texts_from(text.as_bytes(), Path::new("l.csv")).unwrap();
        let dog = &t["noto/dog-face.svg"];
        assert_eq!(dog.name, "noto/dog-face");
        assert_eq!(dog.keywords, ["adorbs", "dog", "pet"]);
        assert_eq!(
            dog.category.as_deref(),
            Some("animals-nature/animal-mammal")
        );
        assert_eq!(t["noto/apple.svg"].category.as_deref(), Some("food-drink"));
        let all = texts_for(
            &["noto/apple.svg".into(), "x/unlisted.png".into()],
            Some(&t),
        );
        assert_eq!(all[1], ItemText::from_id("x/unlisted.png"));
    }

    #[test]
    fn explicit_columns_and_errors() {
        let text = "id,name,tags,category\na,Red apple,\"fruit, red\",food\n";
        let t = read_item_texts_from(text.as_bytes(), Path::new("t.csv")).unwrap();
        assert_eq!(t["a"].name, "Red apple");
        assert_eq!(t["a"].tags, ["fruit", "red"]);
        assert_eq!(t["a"].category.as_deref(), Some("food"));
        let e = read_item_texts_from("style\nx\n".as_bytes(), Path::new("t.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.csv:1") && e.contains("`file`"), "{e}");
        let e = read_item_texts_from("id\na\na\n".as_bytes(), Path::new("t.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.csv:3") && e.contains("duplicate"), "{e}");
    }
}
