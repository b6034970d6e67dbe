//! Keyword search over item names, tags and keywords: the first half of the paper's search
//! (§5.7.3, Garces et al. 2014 used Lucene), here with tantivy: BM25 on exact words, plus prefix
//! matches (search as you type) and fuzzy matches (typos), and a category facet to filter by.
//!
//! Each query word must match in some field (AND across words). A word scores BM25 where it is
//! an indexed word (the name counts double), a constant 0.5 where it is only the prefix of one,
//! and 0.3 where it is only within the Levenshtein distance Lucene's `AUTO` fuzziness allows
//! (0 edits up to 2 letters, 1 up to 5, 2 beyond; a transposition counts as one edit). Text is
//! split on anything that is not a letter or digit, lower-cased and folded to ASCII, in the
//! index and in queries alike. Documents carry no stored fields: a fast field holds each item's
//! row, everything else lives in the style index.
//!
//! * `text`: [`ItemText`] and the analyser; `collect`: the collector of every match.

mod collect;
mod text;

use std::path::Path;

use tantivy::query::{BooleanQuery, BoostQuery, FuzzyTermQuery, Occur, Query, TermQuery};
use tantivy::schema::{
    FAST, FacetOptions, Field, IndexRecordOption, Schema, TextFieldIndexing, TextOptions,
};
use tantivy::{Index, IndexReader, ReloadPolicy, TantivyDocument, Term};

use crate::{Error, Result};
use collect::AllHits;
pub use text::{ItemText, name_from_id, words};
use text::{analyser, facet};

/// The analyser's name in the tantivy index.
const TOKENIZER: &str = "stylekit";
/// Indexing memory (one writer thread, so document order is row order).
const WRITER_BUDGET: usize = 64 << 20;
/// Score of a word that is only a prefix of an indexed word.
const PREFIX_SCORE: f32 = 0.5;
/// Score of a word that is only a fuzzy match.
const FUZZY_SCORE: f32 = 0.3;
/// The name's weight against tags and keywords.
const NAME_BOOST: f32 = 2.0;

fn tantivy_error(what: &'static str) -> impl Fn(tantivy::TantivyError) -> Error {
    move |e| Error::Keywords {
        what,
        message: e.to_string(),
    }
}

/// The keyword index of a library (in memory or in a folder).
pub struct KeywordIndex {
    reader: IndexReader,
    name: Field,
    tags: Field,
    keywords: Field,
    category: Field,
}

impl std::fmt::Debug for KeywordIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KeywordIndex")
            .field("documents", &self.reader.searcher().num_docs())
            .finish()
    }
}

impl KeywordIndex {
    /// Indexes `texts` (row `i` is `texts[i]`), in memory or in the empty folder `dir`.
    /// `progress(done)` is called every few thousand items.
    pub fn build(
        texts: &[ItemText],
        dir: Option<&Path>,
        progress: &mut dyn FnMut(usize),
    ) -> Result<Self> {
        let mut schema = Schema::builder();
        let text = TextOptions::default().set_indexing_options(
            TextFieldIndexing::default()
                .set_tokenizer(TOKENIZER)
                .set_index_option(IndexRecordOption::WithFreqs),
        );
        schema.add_u64_field("row", FAST);
        let name = schema.add_text_field("name", text.clone());
        let tags = schema.add_text_field("tags", text.clone());
        let keywords = schema.add_text_field("keywords", text);
        let category = schema.add_facet_field("category", FacetOptions::default());
        let schema = schema.build();
        let index = match dir {
            Some(dir) => {
                Index::create_in_dir(dir, schema).map_err(tantivy_error("creating the index"))?
            }
            None => Index::create_in_ram(schema),
        };
        index.tokenizers().register(TOKENIZER, analyser());
        let row = index
            .schema()
            .get_field("row")
            .map_err(tantivy_error("schema"))?;
        let mut writer = index
            .writer_with_num_threads::<TantivyDocument>(1, WRITER_BUDGET)
            .map_err(tantivy_error("opening the writer"))?;
        for (i, t) in texts.iter().enumerate() {
            let mut doc = TantivyDocument::default();
            doc.add_u64(row, i as u64);
            doc.add_text(name, &t.name);
            for tag in &t.tags {
                doc.add_text(tags, tag);
            }
            for word in &t.keywords {
                doc.add_text(keywords, word);
            }
            if let Some(c) = &t.category {
                doc.add_facet(category, facet(c));
            }
            writer
                .add_document(doc)
                .map_err(tantivy_error("adding a document"))?;
            if (i + 1) % 4096 == 0 {
                progress(i + 1);
            }
        }
        writer.commit().map_err(tantivy_error("committing"))?;
        writer
            .wait_merging_threads()
            .map_err(tantivy_error("merging"))?;
        progress(texts.len());
        Self::from_index(index)
    }

    /// Opens an index written by [`KeywordIndex::build`] into `dir`.
    pub fn open(dir: &Path) -> Result<Self> {
        let index = Index::open_in_dir(dir).map_err(tantivy_error("opening the index"))?;
        index.tokenizers().register(TOKENIZER, analyser());
        Self::from_index(index)
    }

    fn from_index(index: Index) -> Result<Self> {
        let schema = index.schema();
        let field = |name: &str| schema.get_field(name).map_err(tantivy_error("schema"));
        let reader = index
            .reader_builder()
            .reload_policy(ReloadPolicy::Manual)
            .try_into()
            .map_err(tantivy_error("opening a reader"))?;
        Ok(Self {
            name: field("name")?,
            tags: field("tags")?,
            keywords: field("keywords")?,
            category: field("category")?,
            reader,
        })
    }

    /// Documents in the index.
    pub fn len(&self) -> usize {
        self.reader.searcher().num_docs() as usize
    }

    /// True without documents.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every item matching `text` (all words) and within `category`, as `(row, score)` in row
    /// order. `text` must hold at least one word; with only a category, every item in it
    /// matches with score 1.
    pub fn search(&self, text: Option<&str>, category: Option<&str>) -> Result<Vec<(u32, f32)>> {
        let mut clauses: Vec<(Occur, Box<dyn Query>)> = Vec::new();
        if let Some(text) = text {
            let words = words(text);
            if words.is_empty() {
                return Err(Error::EmptyQuery("the keywords hold no searchable word"));
            }
            for w in &words {
                clauses.push((Occur::Must, Box::new(self.word_query(w))));
            }
        }
        if let Some(c) = category {
            let term = Term::from_facet(self.category, &facet(c));
            clauses.push((
                Occur::Must,
                Box::new(TermQuery::new(term, IndexRecordOption::Basic)),
            ));
        }
        if clauses.is_empty() {
            return Err(Error::EmptyQuery("no keywords and no category"));
        }
        let query = BooleanQuery::new(clauses);
        let searcher = self.reader.searcher();
        let mut hits = searcher
            .search(&query, &AllHits)
            .map_err(tantivy_error("searching"))?;
        hits.sort_unstable_by_key(|h| h.0);
        Ok(hits)
    }

    /// One word: exact in any field (BM25), or a prefix, or a near miss.
    fn word_query(&self, word: &str) -> BooleanQuery {
        let edits = match word.chars().count() {
            0..=2 => 0,
            3..=5 => 1,
            _ => 2,
        };
        let mut alternatives: Vec<(Occur, Box<dyn Query>)> = Vec::new();
        for (field, boost) in [
            (self.name, NAME_BOOST),
            (self.tags, 1.0),
            (self.keywords, 1.0),
        ] {
            let term = Term::from_field_text(field, word);
            alternatives.push((
                Occur::Should,
                Box::new(BoostQuery::new(
                    Box::new(TermQuery::new(term.clone(), IndexRecordOption::WithFreqs)),
                    boost,
                )),
            ));
            alternatives.push((
                Occur::Should,
                Box::new(BoostQuery::new(
                    Box::new(FuzzyTermQuery::new_prefix(term.clone(), 0, true)),
                    PREFIX_SCORE,
                )),
            ));
            if edits > 0 {
                alternatives.push((
                    Occur::Should,
                    Box::new(BoostQuery::new(
                        Box::new(FuzzyTermQuery::new(term, edits, true)),
                        FUZZY_SCORE,
                    )),
                ));
            }
        }
        BooleanQuery::new(alternatives)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn library() -> KeywordIndex {
        let texts = vec![
            ItemText {
                name: "noto/dog-face".into(),
                keywords: vec!["puppy".into(), "pet".into()],
                category: Some("animals-nature/animal-mammal".into()),
                ..Default::default()
            },
            ItemText {
                name: "noto/cat-face".into(),
                keywords: vec!["kitten".into(), "pet".into()],
                category: Some("animals-nature/animal-mammal".into()),
                ..Default::default()
            },
            ItemText {
                name: "twemoji/hot-dog".into(),
                tags: vec!["food".into()],
                category: Some("food-drink".into()),
                ..Default::default()
            },
            ItemText::from_id("game-icons/Éléphant.svg"),
        ];
        KeywordIndex::build(&texts, None, &mut |_| {}).unwrap()
    }

    fn rows(hits: &[(u32, f32)]) -> Vec<u32> {
        hits.iter().map(|h| h.0).collect()
    }

    #[test]
    fn exact_prefix_and_fuzzy_words() {
        let k = library();
        assert_eq!(k.len(), 4);
        assert_eq!(rows(&k.search(Some("dog"), None).unwrap()), [0, 2]);
        assert_eq!(rows(&k.search(Some("pupp"), None).unwrap()), [0]);
        assert_eq!(rows(&k.search(Some("kiten"), None).unwrap()), [1]);
        assert_eq!(rows(&k.search(Some("Elephant"), None).unwrap()), [3]);
        assert_eq!(rows(&k.search(Some("pet face"), None).unwrap()), [0, 1]);
        assert!(k.search(Some("zebra"), None).unwrap().is_empty());
    }

    #[test]
    fn exact_words_outscore_prefixes_and_names_outscore_keywords() {
        let k = library();
        let hits = k.search(Some("do"), None).unwrap();
        assert_eq!(rows(&hits), [0, 2]);
        let hits = k.search(Some("dog"), None).unwrap();
        let prefix = k.search(Some("do"), None).unwrap();
        assert!(hits[0].1 > prefix[0].1);
        let pet = k.search(Some("pet"), None).unwrap();
        assert!(pet[0].1 < hits[0].1 + 10.0);
    }

    #[test]
    fn category_facet_filters_and_matches_subcategories() {
        let k = library();
        assert_eq!(
            rows(&k.search(Some("dog"), Some("food-drink")).unwrap()),
            [2]
        );
        assert_eq!(
            rows(&k.search(None, Some("/animals-nature")).unwrap()),
            [0, 1]
        );
        assert!(k.search(None, Some("vehicles")).unwrap().is_empty());
    }

    #[test]
    fn empty_queries_are_errors() {
        let k = library();
        for q in ["", "  ", "!?-"] {
            assert!(matches!(k.search(Some(q), None), Err(Error::EmptyQuery(_))));
        }
        assert!(matches!(k.search(None, None), Err(Error::EmptyQuery(_))));
    }

    #[test]
    fn on_disk_index_reopens() {
        let dir = tempfile::tempdir().unwrap();
        let texts = vec![
            ItemText::from_id("a/red-apple.svg"),
            ItemText::from_id("b/pear.svg"),
        ];
        KeywordIndex::build(&texts, Some(dir.path()), &mut |_| {}).unwrap();
        let k = KeywordIndex::open(dir.path()).unwrap();
        assert_eq!(rows(&k.search(Some("aple"), None).unwrap()), [0]);
    }
}
