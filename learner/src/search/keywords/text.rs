//! The text side of the keyword index: an item's words, and the analyser that splits and
//! folds them the same way in the index and in queries.

use tantivy::schema::Facet;
use tantivy::tokenizer::{
    AsciiFoldingFilter, LowerCaser, RemoveLongFilter, SimpleTokenizer, TextAnalyzer,
};

/// The text of one item.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ItemText {
    /// Its name (by default the id's words: `noto/dog-face.svg` → `noto dog face`).
    pub name: String,
    /// Tags (e.g. Iconify categories, or words an uploader gave).
    pub tags: Vec<String>,
    /// Keywords (e.g. CLDR annotations of an emoji).
    pub keywords: Vec<String>,
    /// A category path for the facet filter (`animals-nature`, or `animals-nature/animal-mammal`
    /// for a subcategory; a filter on a category matches its subcategories).
    pub category: Option<String>,
}

impl ItemText {
    /// The text of an item known only by its id: the id's words without a file extension.
    pub fn from_id(id: &str) -> Self {
        Self {
            name: name_from_id(id),
            ..Self::default()
        }
    }
}

/// `noto/dog-face.svg` → `noto/dog-face`; `noto:dog-face` stays (the tokenizer splits both).
pub fn name_from_id(id: &str) -> String {
    let file_start = id.rfind(['/', '\\']).map_or(0, |i| i + 1);
    match id[file_start..].rfind('.') {
        Some(dot) if dot > 0 => id[..file_start + dot].to_string(),
        _ => id.to_string(),
    }
}

/// Splits on anything that is not a letter or digit, lower-cases and folds to ASCII.
pub(super) fn analyser() -> TextAnalyzer {
    TextAnalyzer::builder(SimpleTokenizer::default())
        .filter(RemoveLongFilter::limit(40))
        .filter(LowerCaser)
        .filter(AsciiFoldingFilter)
        .build()
}

/// The words of a query, as the index sees them.
pub fn words(text: &str) -> Vec<String> {
    let mut analyser = analyser();
    let mut stream = analyser.token_stream(text);
    let mut out: Vec<String> = Vec::new();
    while stream.advance() {
        let t = stream.token().text.clone();
        if !out.contains(&t) {
            out.push(t);
        }
    }
    out
}

/// `animals-nature/animal-mammal` (or with a leading `/`) as a facet path.
pub(super) fn facet(category: &str) -> Facet {
    Facet::from_path(category.split('/').map(str::trim).filter(|p| !p.is_empty()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_from_ids() {
        assert_eq!(name_from_id("noto/dog-face.svg"), "noto/dog-face");
        assert_eq!(name_from_id("noto:dog-face"), "noto:dog-face");
        assert_eq!(name_from_id("v1.2/.hidden"), "v1.2/.hidden");
        assert_eq!(words("Noto/Dog-Face"), ["noto", "dog", "face"]);
    }
}
