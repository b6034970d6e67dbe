//! Unit tests of the export's file list, options and XML.

use super::*;

#[test]
fn external_question_escapes_the_url() {
    let x = external_question_xml("https://h/s/1?a=1&b=2");
    assert!(x.contains("<ExternalURL>https://h/s/1?a=1&amp;b=2</ExternalURL>"));
}

#[test]
fn every_file_but_the_xml_and_manifest_has_a_dictionary_entry() {
    let described: Vec<&str> = columns::TABLES.iter().map(|t| t.file).collect();
    let csvs: Vec<&str> = FILES
        .iter()
        .copied()
        .filter(|f| f.ends_with(".csv"))
        .collect();
    assert_eq!(described, csvs);
    for f in columns::PAYMENT_FILES {
        assert!(FILES.contains(&f), "{f}");
    }
}

#[test]
fn options_filter_hits_and_make_links() {
    let default = ExportOptions::default();
    assert!(default.includes("completed", Some("approved")));
    assert!(default.includes("completed", None));
    assert!(!default.includes("completed", Some("rejected")));
    assert!(!default.includes("active", None));
    let all = ExportOptions {
        include_controls: true,
        include_rejected: true,
        include_incomplete: true,
        pseudonymous: false,
    };
    assert!(all.includes("screened_out", Some("rejected")));
    assert_eq!(default.query(), "");
    assert_eq!(
        all.query(),
        "?include_controls=true&include_rejected=true&include_incomplete=true"
    );
}
