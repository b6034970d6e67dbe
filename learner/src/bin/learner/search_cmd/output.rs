//! What `learner search` reads besides the index (`--example` drawings) and what it prints.

use std::path::Path;

use anyhow::{Context, Result, bail};
use learner::features;
use learner::search::{Order, Query, SearchIndex, SearchResults};

/// The features of a drawing, in the index's column order.
pub(super) fn featurise(path: &Path, index: &SearchIndex) -> Result<Vec<f64>> {
    let names: Vec<&str> = features::catalogue().iter().map(|f| f.name).collect();
    if index.feature_names() != names.as_slice() {
        bail!(
            "--example needs a library of the {} features of `learner features`; {} has {} other \
             columns",
            names.len(),
            "this index",
            index.feature_names().len()
        );
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let canvas = match ext.as_str() {
        "svg" => learner::render::render_svg(&learner::input::read_limited(
            path,
            learner::render::MAX_SVG_BYTES,
        )?),
        "png" | "jpg" | "jpeg" => learner::render::render_raster(&learner::input::read_limited(
            path,
            learner::render::MAX_RASTER_BYTES,
        )?),
        _ => bail!(
            "--example {}: expected an .svg, .png, .jpg or .jpeg file",
            path.display()
        ),
    }
    .with_context(|| format!("--example {}", path.display()))?;
    let values =
        features::extract(canvas).with_context(|| format!("--example {}", path.display()))?;
    Ok(values.to_vec())
}

pub(super) fn print_json(results: &SearchResults) -> Result<()> {
    let rows: Vec<serde_json::Value> = results
        .hits
        .iter()
        .map(|h| {
            // `distance` only when there are references (mean eq.-5.5 distance to them),
            // `cluster` only in the diversity order: absent rather than null.
            let mut row = serde_json::json!({ "id": h.id });
            if let Some(d) = h.distance {
                row["distance"] = serde_json::json!(d);
            }
            if let Some(s) = h.score {
                row["score"] = serde_json::json!(s);
            }
            if let Some(c) = h.cluster {
                row["cluster"] = serde_json::json!(c.top);
                row["subcluster"] = serde_json::json!(c.leaf);
            }
            row
        })
        .collect();
    let out = serde_json::json!({
        "order": results.order,
        "matched": results.matched,
        "results": rows,
    });
    outln!("{out}")
}

pub(super) fn print_table(results: &SearchResults, query: &Query) -> Result<()> {
    let refs = query.near.len() + query.examples.len();
    let order = match results.order {
        Order::Style if refs == 1 => "by style distance to the reference".to_string(),
        Order::Style => format!("by mean style distance to the {refs} references"),
        Order::Diversity => "dealt across style clusters".to_string(),
        Order::Relevance => "by keyword relevance".to_string(),
        Order::Random => "in a seeded random order".to_string(),
    };
    eprintln!(
        "{} matched, first {} {order}",
        results.matched,
        results.hits.len()
    );
    for (rank, h) in results.hits.iter().enumerate() {
        let mut line = format!("{:>4}  ", rank + 1);
        if let Some(d) = h.distance {
            line.push_str(&format!("{d:>10.4}  "));
        }
        if let Some(c) = h.cluster {
            line.push_str(&format!("{:>2}/{:<3}  ", c.top, c.leaf));
        }
        line.push_str(&h.id);
        outln!("{line}")?;
    }
    Ok(())
}
