//! Helpers shared by the CLI test binaries: run the real `decompose` binary.

use std::ffi::OsStr;
use std::path::PathBuf;
use std::process::{Command, Output};

/// A committed fixture folder, `fixtures/<name>`.
pub fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures")
        .join(name)
}

/// Runs `decompose` with `args` and collects its output.
pub fn decompose(args: &[&OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_decompose"))
        .args(args)
        .output()
        .expect("run decompose")
}

/// `s` as an argument.
pub fn os(s: &str) -> &OsStr {
    OsStr::new(s)
}
