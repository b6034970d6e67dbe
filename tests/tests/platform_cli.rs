//! The `platform` command line with bad input: a readable `error:` line on stderr and a failing exit
//! status, also when `RUST_BACKTRACE` is set in the environment (an input error is not a crash).

use e2e::platform::*;

#[test]
fn validation_errors_are_one_line_even_with_rust_backtrace() {
    let db = sqlite_db();
    for backtrace in ["1", "full"] {
        for args in [
            vec![
                "study",
                "status",
                "12345",
                "--database-url",
                db.url.as_str(),
            ],
            vec![
                "library",
                "import",
                "--database-url",
                db.url.as_str(),
                "/no/such/folder",
            ],
            vec![
                "serve",
                "--database-url",
                "mysql://nope",
                "--bind",
                "127.0.0.1:0",
            ],
        ] {
            let out = platform_cmd(&args, &[("RUST_BACKTRACE", backtrace)]);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
            let last = stderr.trim().lines().last().unwrap_or_default();
            assert!(last.starts_with("error: "), "{args:?}: {stderr}");
            assert!(
                !stderr.to_lowercase().contains("backtrace") && !stderr.contains("src/"),
                "{args:?} with RUST_BACKTRACE={backtrace}: {stderr}"
            );
        }
    }
}

/// A blank drawing between two good ones (issue 16: it aborted the whole import, with an error
/// that did not name the file): it is skipped and listed with its file and the reason, the
/// items after it are stored, label rows naming no file are warned about, and an import that
/// stores nothing fails.
#[test]
fn a_blank_drawing_is_skipped_and_named_and_the_import_goes_on() {
    let db = sqlite_db();
    let dir = tempfile::tempdir().expect("temp dir");
    let drawing = |fill: &str| {
        format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10"><circle cx="5" cy="5" r="4" fill="{fill}"/></svg>"#
        )
    };
    std::fs::write(dir.path().join("a.svg"), drawing("teal")).expect("write");
    std::fs::write(dir.path().join("b-blank.svg"), drawing("white")).expect("write");
    std::fs::write(dir.path().join("c.svg"), drawing("crimson")).expect("write");
    let labels = dir.path().join("labels.csv");
    std::fs::write(
        &labels,
        "file,style\na.svg,flat\n,flat\nmissing.svg,ink\nc.svg,ink\n",
    )
    .expect("write labels");
    let (dir_arg, labels_arg) = (dir.path().to_string_lossy(), labels.to_string_lossy());
    let import = |path: &str, labels: Option<&str>| {
        let mut args = vec!["library", "import", "--database-url", db.url.as_str()];
        if let Some(l) = labels {
            args.extend(["--labels", l]);
        }
        args.push(path);
        platform_cmd(&args, &[])
    };
    let out = import(&dir_arg, Some(&labels_arg));
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("imported 2 item(s)") && stdout.contains("1 skipped"),
        "{stdout}"
    );
    let blank = dir.path().join("b-blank.svg");
    assert!(
        stderr.contains(&format!("skipped {}: blank drawing", blank.display())),
        "{stderr}"
    );
    assert!(stderr.contains("line 3: the row names no file"), "{stderr}");
    assert!(
        stderr.contains("line 4") && stderr.contains("\"missing.svg\""),
        "{stderr}"
    );
    // Nothing usable: a failure a script sees.
    let out = import(&blank.to_string_lossy(), None);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("nothing imported"), "{stderr}");
}

/// Issue 16: `demo --help` named `platform.db` while the demo wrote `platform-demo.db`, and
/// `demo --no-serve` printed a listening address although nothing listened.
#[test]
fn the_demo_says_which_database_it_uses_and_does_not_claim_to_listen() {
    let run = |args: &[&str], dir: &std::path::Path| {
        let out = std::process::Command::new(e2e::binary("platform", "platform"))
            .args(args)
            .current_dir(dir)
            .env_remove("PLATFORM_DATABASE_URL")
            .env_remove("PLATFORM_BIND")
            .output()
            .expect("run platform");
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let help = run(&["demo", "--help"], dir.path());
    assert!(
        help.contains("[default: sqlite://platform-demo.db]"),
        "{help}"
    );
    let help = run(&["serve", "--help"], dir.path());
    assert!(help.contains("[default: sqlite://platform.db]"), "{help}");

    let fixtures = e2e::fixture("style");
    let printed = run(
        &[
            "demo",
            "--no-serve",
            "--fixtures",
            &fixtures.to_string_lossy(),
        ],
        dir.path(),
    );
    assert!(!printed.contains("listening on"), "{printed}");
    // The links point where `platform serve` listens by default.
    assert!(
        printed.contains("worker link: http://127.0.0.1:8080/s/"),
        "{printed}"
    );
    assert!(dir.path().join("platform-demo.db").exists());
    assert!(!dir.path().join("platform.db").exists());
}
