//! Helpers shared by the end-to-end tests in `tests/tests/`: where the workspace is and how to
//! run its real binaries.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;

/// The workspace root (the parent of this crate's folder).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate lives one level below the workspace root")
        .to_path_buf()
}

/// A fixture path below `fixtures/`.
pub fn fixture(relative: &str) -> PathBuf {
    workspace_root().join("fixtures").join(relative)
}

/// The path of a workspace binary built in the same profile as this test. The first call in a
/// test process runs `cargo build` for it (a no-op when it is up to date), so a test never runs
/// a stale binary when only this crate's tests were selected.
///
/// `scripts/test` sets `E2E_BINARIES_BUILT=1`: its `cargo nextest run --workspace` has just
/// built every binary (as the packages' own integration tests need them), and a `cargo build -p`
/// here would resolve features differently (no dev-dependencies) and compile the dependency tree
/// a second time.
pub fn binary(package: &str, name: &str) -> PathBuf {
    static BUILT: Mutex<Vec<String>> = Mutex::new(Vec::new());
    // target/<profile>/deps/<test-exe> → target/<profile>/<name>
    let exe = std::env::current_exe().expect("test executable path");
    let profile_dir = exe
        .parent()
        .and_then(Path::parent)
        .expect("test executable in target/<profile>/deps");
    let prebuilt = std::env::var_os("E2E_BINARIES_BUILT").is_some_and(|v| v == "1")
        && profile_dir.join(name).is_file();
    let mut built = BUILT.lock().unwrap_or_else(|e| e.into_inner());
    if !prebuilt && !built.iter().any(|b| b == name) {
        let profile = profile_dir
            .file_name()
            .and_then(|p| p.to_str())
            .unwrap_or("debug");
        let mut cmd = Command::new(env!("CARGO"));
        cmd.args(["build", "--quiet", "-p", package, "--bin", name])
            .current_dir(workspace_root());
        if profile != "debug" {
            cmd.args(["--profile", profile]);
        }
        let status = cmd.status().expect("run cargo build");
        assert!(
            status.success(),
            "cargo build -p {package} --bin {name} failed"
        );
        built.push(name.to_string());
    }
    profile_dir.join(name)
}

/// Runs `learner` with `args` and returns its output.
pub fn learner(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(binary("learner", "learner"))
        .args(args)
        .output()
        .expect("run learner")
}

pub mod browser;
pub mod platform;
