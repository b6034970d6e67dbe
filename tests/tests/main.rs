//! The end-to-end tests: one test binary with a module per area. Each module used to be a test
//! binary of its own, and compiling and linking fifteen binaries of ~120 MB cost minutes of every
//! CI run; one binary is compiled and linked once. nextest still runs every test in its own
//! process, so tests share nothing through statics.
//!
//! Select an area with a filter: `cargo nextest run --workspace -E 'test(/^platform_flow::/)'`.

mod learner_cli;
mod learner_explore;
mod learner_search;
mod platform_browser;
mod platform_cli;
mod platform_cluster;
mod platform_consent;
mod platform_explore;
mod platform_flow;
mod platform_iconset;
mod platform_mashup;
mod platform_mashup_browser;
mod platform_mashup_events;
mod platform_mashup_events_browser;
mod platform_mashup_keys;
mod platform_mashup_raster;
mod platform_mashup_study;
mod platform_new_study_forms;
mod platform_openapi;
mod platform_phone;
mod platform_rating;
mod platform_rating_from_mashup;
mod platform_report_export;
mod platform_search;
mod platform_security;
mod platform_settings;
mod platform_study_create;
mod platform_train;
mod platform_workers;

/// A test file added to this folder but not declared above would never be compiled or run
/// (`autotests = false`): every `*.rs` file and every folder here must be a module of this file.
#[test]
fn every_test_file_is_a_module_of_the_test_binary() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let main = std::fs::read_to_string(dir.join("main.rs")).expect("read main.rs");
    let mut missing = Vec::new();
    for entry in std::fs::read_dir(&dir).expect("list tests/") {
        let path = entry.expect("entry").path();
        let name = path
            .file_stem()
            .and_then(|s| s.to_str())
            .expect("utf-8 name");
        let is_module = path.is_dir() || path.extension().is_some_and(|e| e == "rs");
        if is_module && name != "main" && !main.contains(&format!("\nmod {name};")) {
            missing.push(name.to_string());
        }
    }
    assert!(
        missing.is_empty(),
        "not declared in tests/tests/main.rs: {missing:?}"
    );
}
