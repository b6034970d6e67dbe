//! What runs outside the bench's process: a fresh process that loads the saved index (its
//! load time and memory), and the numpy/faiss script on the same matrix and queries.

use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use learner::search::{Query, SearchIndex};
use learner::table::FeatureTable;

use super::data::{Latency, proc_kb};
use super::{BenchSearchArgs, K};

/// In a fresh process: load the index, answer one query, report the time and peak memory.
pub(super) fn measure_load(dir: &Path) -> Result<()> {
    let t = Instant::now();
    let (index, _) = SearchIndex::load(dir)?;
    let load_seconds = t.elapsed().as_secs_f64();
    let r = index.search(&Query {
        near: vec![index.ids()[0].clone()],
        keywords: Some("face".into()),
        ..Query::default()
    })?;
    std::hint::black_box(r);
    outln!(
        "{}",
        serde_json::json!({
            "load_seconds": load_seconds,
            "peak_rss_kb": proc_kb("VmHWM:"),
            "rss_kb": proc_kb("VmRSS:"),
            "heap_estimate_bytes": index.memory_bytes(),
        })
    )
}

/// The side-by-side table: our exact query, then numpy's and faiss's on the same pre-scaled
/// matrix and the same projected queries. A Python side that cannot run (no python3, no numpy,
/// no faiss) is a "skipped" row with the reason, not a failure of the bench.
pub(super) fn python_side_by_side(
    a: &BenchSearchArgs,
    index: &SearchIndex,
    table: &FeatureTable,
    rows: &[usize],
    ours: &[Vec<u32>],
    our_latency: &Latency,
) -> Result<serde_json::Value> {
    outln!(
        "\nside by side: exact top {K} by example over the same pre-scaled matrix, one query at a \
         time, one thread"
    )?;
    outln!(
        "{:<36} {:>8} {:>8} {:>16} {:>16}",
        "engine",
        "p50 ms",
        "p99 ms",
        "p50 ÷ ours (p50)",
        "top-50 overlap"
    )?;
    outln!(
        "{:<36} {:>8.2} {:>8.2} {:>16} {:>16}",
        "stylekit (f32 scan, bounded heap)",
        our_latency.p50,
        our_latency.p99,
        "1.0",
        "—"
    )?;
    let py = match run_python(a, index, table, rows, ours) {
        Ok(py) => py,
        Err(e) => {
            let reason = format!("{e:#}").replace('\n', " ");
            serde_json::json!({
                "numpy_gemv": {"skipped": reason},
                "numpy_direct": {"skipped": reason},
                "faiss_flat_l2": {"skipped": reason},
            })
        }
    };
    for (key, name) in [
        ("numpy_gemv", "numpy ‖x‖²−2x·q+‖q‖², argpartition"),
        ("numpy_direct", "numpy Σ(x−q)², argpartition"),
        ("faiss_flat_l2", "faiss IndexFlatL2"),
    ] {
        let e = &py[key];
        if let Some(reason) = e["skipped"].as_str() {
            outln!("{name:<36} skipped: {reason}")?;
            continue;
        }
        let p50 = e["p50"].as_f64().unwrap_or(f64::NAN);
        outln!(
            "{name:<36} {p50:>8.2} {:>8.2} {:>16.2} {:>15.1}%",
            e["p99"].as_f64().unwrap_or(f64::NAN),
            p50 / our_latency.p50,
            e["agreement"].as_f64().unwrap_or(f64::NAN) * 100.0
        )?;
    }
    if let Some(v) = py.get("versions") {
        outln!("(versions: {v})")?;
    }
    Ok(py)
}

/// Writes the pre-scaled matrix and the projected queries and runs the Python script on them.
fn run_python(
    a: &BenchSearchArgs,
    index: &SearchIndex,
    table: &FeatureTable,
    rows: &[usize],
    ours: &[Vec<u32>],
) -> Result<serde_json::Value> {
    if !a.python_script.is_file() {
        bail!(
            "{} not found (run from the workspace root)",
            a.python_script.display()
        );
    }
    let dir = tempfile::tempdir()?;
    let mut w = std::io::BufWriter::new(std::fs::File::create(dir.path().join("matrix.f32"))?);
    for v in index.matrix().data() {
        w.write_all(&v.to_le_bytes())?;
    }
    w.flush()?;
    let mut w = std::io::BufWriter::new(std::fs::File::create(dir.path().join("queries.f32"))?);
    for &r in rows {
        for v in index.matrix().project(table.row(r))? {
            w.write_all(&v.to_le_bytes())?;
        }
    }
    w.flush()?;
    std::fs::write(
        dir.path().join("ours.json"),
        serde_json::to_vec(&serde_json::json!({
            "n": index.len(), "stride": index.matrix().stride(), "k": K, "rows": ours,
        }))?,
    )?;
    eprintln!("timing numpy and faiss on the same matrix and queries…");
    let out = Command::new("python3")
        .arg(&a.python_script)
        .arg(dir.path())
        .args(["--k", &K.to_string()])
        .env("OMP_NUM_THREADS", "1")
        .env("OPENBLAS_NUM_THREADS", "1")
        .env("MKL_NUM_THREADS", "1")
        .output()
        .context("python3 not runnable")?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        bail!(
            "{} failed ({}): {}",
            a.python_script.display(),
            out.status,
            err.lines().last().unwrap_or("").trim()
        );
    }
    Ok(serde_json::from_slice(&out.stdout)?)
}
