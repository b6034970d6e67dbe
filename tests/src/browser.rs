//! Real Chromium over WebDriver (Debian's chromium and chromium-driver), for the browser tests:
//! a session on a desktop window or an emulated phone, screenshots, the console's
//! Content-Security-Policy reports, and waiting for navigations.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::json;

use crate::platform::{client, send};

/// The screen a session emulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Viewport {
    /// A 1100×1000 desktop window.
    Desktop,
    /// A phone of this CSS width × height (Chromium's device emulation: the viewport is
    /// exactly this size, touch events on, the page's `<meta name=viewport>` applied).
    Phone(u32, u32),
}

/// A running chromedriver and its port.
pub struct Driver(Child, u16);

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A free TCP port on loopback.
pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("free port")
}

/// The path of an installed program in /usr/bin or /usr/local/bin.
pub fn tool(name: &str) -> Option<PathBuf> {
    ["/usr/bin", "/usr/local/bin"]
        .iter()
        .map(|d| Path::new(d).join(name))
        .find(|p| p.exists())
}

/// A WebDriver session, or `None` (locally) when Chromium is not installed; in CI (`CI=true`)
/// a missing Chromium fails the test.
pub async fn browser(profile: &Path, viewport: Viewport) -> Option<(Driver, Client)> {
    let (Some(chromium), Some(chromedriver)) = (tool("chromium"), tool("chromedriver")) else {
        if std::env::var("CI").is_ok_and(|v| v == "true" || v == "1") {
            panic!("chromium and chromedriver are required in CI (scripts/test installs them)");
        }
        eprintln!("chromium/chromedriver not installed: skipping the browser test");
        return None;
    };
    let port = free_port();
    let driver = Driver(
        Command::new(chromedriver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start chromedriver"),
        port,
    );
    let mut caps = json!({
        // The browser's console, where Chromium reports Content-Security-Policy violations.
        "goog:loggingPrefs": {"browser": "ALL"},
        "goog:chromeOptions": {
            "binary": chromium,
            "args": [
                "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--window-size=1100,1000", format!("--user-data-dir={}", profile.display()),
            ]
        }
    });
    if let Viewport::Phone(width, height) = viewport {
        caps["goog:chromeOptions"]["mobileEmulation"] = json!({
            "deviceMetrics": {"width": width, "height": height, "pixelRatio": 3.0, "touch": true},
            "userAgent": "Mozilla/5.0 (Linux; Android 14; Pixel 8) AppleWebKit/537.36 \
                (KHTML, like Gecko) Chrome/156.0 Mobile Safari/537.36",
        });
    }
    let caps: fantoccini::wd::Capabilities = caps.as_object().expect("object").clone();
    let connector = hyper_util::client::legacy::connect::HttpConnector::new();
    for _ in 0..100 {
        match ClientBuilder::new(connector.clone())
            .capabilities(caps.clone())
            .connect(&format!("http://127.0.0.1:{port}"))
            .await
        {
            Ok(c) => return Some((driver, c)),
            Err(_) => tokio::time::sleep(Duration::from_millis(100)).await,
        }
    }
    panic!("could not open a WebDriver session");
}

/// The browser console's Content-Security-Policy violation reports since the last call
/// (chromedriver's log endpoint; reading the log empties it).
pub async fn csp_violations(c: &Client, driver: &Driver) -> Vec<String> {
    let session = c
        .session_id()
        .await
        .expect("session id")
        .expect("a WebDriver session");
    let (status, log) = send(
        client()
            .post(format!(
                "http://127.0.0.1:{}/session/{session}/se/log",
                driver.1
            ))
            .json(&json!({"type": "browser"})),
    )
    .await;
    assert_eq!(status, 200, "browser log: {log}");
    log["value"]
        .as_array()
        .expect("log entries")
        .iter()
        .filter_map(|e| e["message"].as_str())
        .filter(|m| m.contains("Content Security Policy"))
        .map(str::to_string)
        .collect()
}

/// Saves a screenshot of the page as `dir/name`.
pub async fn shot(c: &Client, dir: &Path, name: &str) {
    let png = c.screenshot().await.expect("screenshot");
    std::fs::write(dir.join(name), png).expect("write screenshot");
}

/// The item id of an image address `/media/items/ID.png`.
pub fn id_from_src(src: &str) -> i64 {
    src.rsplit('/')
        .next()
        .and_then(|f| f.strip_suffix(".png"))
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("image src {src}"))
}

/// An attribute of the first element matching `css` (empty when absent).
pub async fn attr(c: &Client, css: &str, name: &str) -> String {
    c.find(Locator::Css(css))
        .await
        .unwrap_or_else(|e| panic!("{css}: {e}"))
        .attr(name)
        .await
        .expect("attr")
        .unwrap_or_default()
}

/// Marks the current document; [`wait_navigated`] waits until a new one has loaded.
pub async fn mark(c: &Client) {
    c.execute("window.__old = true; return null;", vec![])
        .await
        .expect("mark");
}

/// Waits until the document marked by [`mark`] has been replaced by a loaded one.
pub async fn wait_navigated(c: &Client) {
    // Up to 20 s (a page load is milliseconds on an idle machine; CI shares it with the rest).
    for _ in 0..800 {
        let done = c
            .execute(
                "return window.__old === undefined && document.readyState === 'complete';",
                vec![],
            )
            .await
            .ok()
            .and_then(|v| v.as_bool())
            .unwrap_or(false);
        if done {
            return;
        }
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
    panic!("the page did not change");
}
