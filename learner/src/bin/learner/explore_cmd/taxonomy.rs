//! `learner taxonomy`: the representative styles of a library (§6.5.1) as JSON, with a contact
//! sheet (one row per representative style: the representative framed, then members nearest
//! it).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use learner::explore::taxonomy::{Stage, TaxonNode};
use learner::explore::{StyleLibrary, Taxonomy, TaxonomyParams, taxonomy};
use serde_json::{Map, Value, json};

use super::library::{LibraryArgs, sheet_path};
use super::sheet::{self, Cell, Thumbnails};

#[derive(Debug, Args)]
pub struct TaxonomyArgs {
    #[command(flatten)]
    pub library: LibraryArgs,
    /// κ: keep branches with more than κ items.
    #[arg(long, default_value_t = TaxonomyParams::default().kappa)]
    pub kappa: usize,
    /// τ: keep branches with more than τ items of every label of --labels.
    #[arg(long, default_value_t = TaxonomyParams::default().tau)]
    pub tau: usize,
    /// Libraries larger than this are clustered on k-means centres (say so in the output).
    #[arg(long, default_value_t = TaxonomyParams::default().max_exact)]
    pub max_exact: usize,
    /// k-means centres for a library larger than --max-exact.
    #[arg(long, default_value_t = TaxonomyParams::default().centres)]
    pub centres: usize,
    /// Seed of the k-means reduction.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Write the JSON here, and the contact sheet beside it (`.png`); without it the JSON goes
    /// to stdout.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Members shown after each representative on the contact sheet.
    #[arg(long, default_value_t = 9)]
    pub sheet_members: usize,
}

pub fn run(args: &TaxonomyArgs) -> Result<()> {
    let library = args.library.load()?;
    let required = args.library.required(&library);
    let params = TaxonomyParams {
        kappa: args.kappa,
        tau: args.tau,
        max_exact: args.max_exact,
        centres: args.centres,
        seed: args.seed,
        ..TaxonomyParams::default()
    };
    let bar = stage_bar(args.library.quiet);
    let result = taxonomy(&library, &required, &params, &mut |stage, done, total| {
        let message = match stage {
            Stage::KMeans => "k-means reduction",
            Stage::Ward => "Ward clustering",
            Stage::Representatives => "representatives",
        };
        bar.set_message(message);
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    let value = to_json(&library, &result);
    if let Some(reduction) = &result.reduction {
        eprintln!(
            "note: {} items are more than --max-exact {}: Ward ran on {} k-means centres",
            result.items, params.max_exact, reduction.centres
        );
    }
    match &args.out {
        None => outln!("{}", serde_json::to_string_pretty(&value)?)?,
        Some(path) => {
            super::write_json(path, &value)?;
            if !args.library.quiet {
                summary(&library, &result);
            }
            if args.library.items.is_empty() {
                eprintln!("no --items given: no contact sheet");
            } else {
                let rows = sheet_rows(&library, &result, args.sheet_members);
                let ids: Vec<&str> = distinct(rows.iter().flatten().copied());
                let thumbs = Thumbnails::render(&args.library.items, &ids, 96, args.library.quiet)?;
                let cells: Vec<Vec<Option<Cell>>> = rows
                    .iter()
                    .map(|row| {
                        row.iter()
                            .enumerate()
                            .map(|(k, id)| Some(Cell { id, framed: k == 0 }))
                            .collect()
                    })
                    .collect();
                let image = sheet::grid(&thumbs, &cells, args.sheet_members + 1);
                sheet::save(
                    &image,
                    &sheet_path(path),
                    thumbs.missing,
                    args.library.quiet,
                )?;
            }
        }
    }
    Ok(())
}

pub(super) fn stage_bar(quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(1).with_style(
        ProgressStyle::with_template("{spinner} {msg:20} [{bar:30}] {pos}/{len} {elapsed}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    bar
}

pub(super) fn distinct<'a>(ids: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    let mut seen = std::collections::HashSet::new();
    ids.filter(|id| seen.insert(*id)).collect()
}

fn labels_json(library: &StyleLibrary, node: &TaxonNode) -> Value {
    let mut map = Map::new();
    for &(l, c) in &node.label_counts {
        map.insert(library.label_names()[l as usize].clone(), json!(c));
    }
    Value::Object(map)
}

/// The format: `representatives: [{id, count, labels}]` and the `tree`, plus members,
/// the parameters and whether Ward ran on k-means centres.
pub fn to_json(library: &StyleLibrary, t: &Taxonomy) -> Value {
    let id = |i: usize| library.ids()[i].clone();
    let representatives: Vec<Value> = t
        .representatives
        .iter()
        .map(|&r| {
            let node = &t.nodes[r];
            json!({
                "id": id(node.representative),
                "count": node.count,
                "labels": labels_json(library, node),
                "members": node.members.iter().map(|&i| id(i)).collect::<Vec<_>>(),
            })
        })
        .collect();
    fn tree(library: &StyleLibrary, t: &Taxonomy, v: usize) -> Value {
        let node = &t.nodes[v];
        json!({
            "id": library.ids()[node.representative],
            "count": node.count,
            "height": node.height,
            "labels": labels_json(library, node),
            "children": node.children.iter().map(|&c| tree(library, t, c)).collect::<Vec<_>>(),
        })
    }
    json!({
        "items": t.items,
        "kappa": t.params.kappa,
        "tau": t.params.tau,
        "required_labels": t.required.iter().map(|&l| library.label_names()[l as usize].clone()).collect::<Vec<_>>(),
        "clustered_on": match &t.reduction {
            None => json!("items"),
            Some(r) => json!({"kmeans_centres": r.centres, "kmeans_iterations": r.kmeans.iterations, "converged": r.kmeans.converged}),
        },
        "unassigned": t.unassigned,
        "representatives": representatives,
        "tree": tree(library, t, 0),
    })
}

fn summary(library: &StyleLibrary, t: &Taxonomy) {
    eprintln!(
        "{} representative styles over {} items ({} in branches too small to keep)",
        t.representatives.len(),
        t.items,
        t.unassigned
    );
    for &r in t.representatives.iter().take(12) {
        let node = &t.nodes[r];
        let labels: Vec<String> = node
            .label_counts
            .iter()
            .take(4)
            .map(|&(l, c)| format!("{} {c}", library.label_names()[l as usize]))
            .collect();
        eprintln!(
            "  {:>6}  {:<40} {}",
            node.count,
            library.ids()[node.representative],
            labels.join(", ")
        );
    }
}

/// One row per representative style: the representative, then the members nearest it.
fn sheet_rows<'a>(library: &'a StyleLibrary, t: &Taxonomy, members: usize) -> Vec<Vec<&'a str>> {
    t.representatives
        .iter()
        .map(|&r| {
            let node = &t.nodes[r];
            let centre = library.row(node.representative);
            let mut near: Vec<(f32, usize)> = node
                .members
                .iter()
                .filter(|&&i| i != node.representative)
                .map(|&i| {
                    let d = library
                        .row(i)
                        .iter()
                        .zip(centre)
                        .map(|(a, b)| (a - b) * (a - b))
                        .sum();
                    (d, i)
                })
                .collect();
            near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            std::iter::once(node.representative)
                .chain(near.iter().take(members).map(|&(_, i)| i))
                .map(|i| library.ids()[i].as_str())
                .collect()
        })
        .collect()
}
