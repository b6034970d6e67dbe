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
