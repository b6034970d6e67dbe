//! The bench's library (real items and jittered copies) and its measurements.

use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

use anyhow::Result;
use learner::metric::model::fit_scaling;
use learner::search::ItemText;
use learner::search::texts::texts_for;
use learner::table::FeatureTable;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The real items, then copies with uniform noise of `jitter` standard deviations per feature
/// (variance-matched: half-width `jitter·σ·√3`), named `<id>#<copy>` with the original's words.
pub(super) fn replicate(
    real: &FeatureTable,
    labels: Option<&HashMap<String, ItemText>>,
    items: usize,
    jitter: f64,
    seed: u64,
) -> Result<(FeatureTable, Vec<ItemText>)> {
    let base = texts_for(real.ids(), labels);
    if items <= real.len() {
        let ids = real.ids()[..items].to_vec();
        let values = real.values()[..items * real.dim()].to_vec();
        let texts = base[..items].to_vec();
        return Ok((
            FeatureTable::new(real.names().to_vec(), ids, values)?,
            texts,
        ));
    }
    let (_, sd) = fit_scaling(real, &[]);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut ids = real.ids().to_vec();
    let mut values = real.values().to_vec();
    let mut texts = base.clone();
    ids.reserve(items - real.len());
    values.reserve((items - real.len()) * real.dim());
    for i in real.len()..items {
        let src = i % real.len();
        ids.push(format!("{}#{}", real.ids()[src], i / real.len()));
        for (v, s) in real.row(src).iter().zip(&sd) {
            values.push(v + rng.random_range(-1.0..1.0) * jitter * s * 3f64.sqrt());
        }
        texts.push(base[src].clone());
    }
    Ok((
        FeatureTable::new(real.names().to_vec(), ids, values)?,
        texts,
    ))
}

/// Latency percentiles in milliseconds.
#[derive(Debug, Clone, Copy)]
pub(super) struct Latency {
    pub(super) p50: f64,
    pub(super) p99: f64,
    pub(super) mean: f64,
}

pub(super) fn time_queries(n: usize, mut f: impl FnMut(usize) -> Result<usize>) -> Result<Latency> {
    // One untimed run warms caches and the allocator.
    std::hint::black_box(f(0)?);
    let mut ms = Vec::with_capacity(n);
    for i in 0..n {
        let t = Instant::now();
        std::hint::black_box(f(i)?);
        ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    ms.sort_by(f64::total_cmp);
    let at = |q: f64| ms[((ms.len() - 1) as f64 * q).round() as usize];
    Ok(Latency {
        p50: at(0.5),
        p99: at(0.99),
        mean: ms.iter().sum::<f64>() / ms.len() as f64,
    })
}

pub(super) fn file_mb(path: &Path) -> f64 {
    std::fs::metadata(path).map_or(f64::NAN, |m| m.len() as f64 / 1e6)
}

pub(super) fn dir_mb(path: &Path) -> f64 {
    walkdir::WalkDir::new(path)
        .into_iter()
        .filter_map(|e| e.ok())
        .filter_map(|e| e.metadata().ok())
        .filter(|m| m.is_file())
        .map(|m| m.len() as f64 / 1e6)
        .sum()
}

/// A size in kB from /proc/self/status (NaN where there is none).
pub(super) fn proc_kb(key: &str) -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .unwrap_or_default()
        .lines()
        .find(|l| l.starts_with(key))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(f64::NAN)
}
