//! `learner grid`: a style branch (or the whole filtered library) laid out on an M×N balanced
//! grid (§6.5.2), or one of the baselines, as JSON (`{"rows", "cols", "nodes": [{"row", "col",
//! "id", "label", "state", "hidden"}]}`) with eq. 6.1's terms and the layout's quality, and a
//! contact sheet of the grid.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use learner::explore::grid::{
    self, BalanceParams, IsoMatchParams, QualityParams, SomParams, isomatch, random_layout,
    som_grid,
};
use learner::explore::{Grid, StyleLibrary};
use serde_json::{Value, json};

use super::library::{LibraryArgs, sheet_path};
use super::sheet::{self, Cell, Thumbnails};
use super::taxonomy::{distinct, stage_bar};

/// How the items are placed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Layout {
    /// SOM then Algorithms 3–4 (the paper's balanced grid).
    Balanced,
    /// The SOM alone.
    Som,
    /// Isomap to 2-D then an optimal assignment to cells (Fried et al. 2015).
    Isomatch,
    /// Items in random cells.
    Random,
}

#[derive(Debug, Args)]
pub struct GridArgs {
    #[command(flatten)]
    pub library: LibraryArgs,
    /// Grid rows M.
    #[arg(long)]
    pub rows: usize,
    /// Grid columns N.
    #[arg(long)]
    pub cols: usize,
    /// The layout.
    #[arg(long, value_enum, default_value_t = Layout::Balanced)]
    pub layout: Layout,
    /// A taxonomy written by `learner taxonomy --out`: lay out one of its branches (--branch).
    #[arg(long, requires = "branch")]
    pub taxonomy: Option<PathBuf>,
    /// The id of the representative style to lay out (with --taxonomy).
    #[arg(long, requires = "taxonomy")]
    pub branch: Option<String>,
    /// Seed of the SOM, the random layout and the quality samples.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Write the JSON here, and the contact sheet beside it (`.png`); without it the JSON goes
    /// to stdout.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also lay the same items on the same grid with the other three layouts and report each
    /// one's eq. 6.1 terms, Spearman, DPQ16 and time (a table on stderr, `comparison` in the
    /// JSON), to see which arrangement keeps style best on this branch.
    #[arg(long)]
    pub compare: bool,
}

/// The items of `library` placed on `args`' grid by `layout`.
fn place(layout: Layout, library: &StyleLibrary, args: &GridArgs) -> Result<Grid> {
    let (points, dim, labels) = (library.points(), library.dim(), library.labels());
    let som_params = SomParams {
        seed: args.seed,
        ..SomParams::new(args.rows, args.cols)
    };
    Ok(match layout {
        Layout::Balanced => {
            grid::balanced_grid(points, dim, labels, &som_params, &BalanceParams::default())?.0
        }
        Layout::Som => som_grid(points, dim, &grid::som(points, dim, &som_params)?)?,
        Layout::Isomatch => isomatch(
            points,
            dim,
            &IsoMatchParams {
                seed: args.seed,
                ..IsoMatchParams::new(args.rows, args.cols)
            },
        )?,
        Layout::Random => random_layout(library.len(), args.rows, args.cols, args.seed)?,
    })
}

/// Eq. 6.1's terms and the quality of `layout` as JSON, and a table row.
fn measure(layout: &Grid, library: &StyleLibrary, seed: u64) -> Result<(Value, String)> {
    let (points, dim, labels) = (library.points(), library.dim(), library.labels());
    let quality = QualityParams {
        seed,
        ..QualityParams::default()
    };
    let cost = grid::cost(layout, labels)?;
    let spearman = grid::layout_spearman(points, dim, layout, &quality).ok();
    let dpq = grid::dpq(points, dim, layout, &quality).ok();
    let shown = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.3}"));
    let row = format!(
        "{:>6} {:>6} {:>9.2} {:>8.2} {:>8} {:>6}",
        cost.empty,
        cost.multi,
        cost.imbalance,
        cost.total,
        shown(spearman),
        shown(dpq)
    );
    let value = json!({
        "cost": {"empty": cost.empty, "multi": cost.multi, "imbalance": cost.imbalance, "total": cost.total},
        "quality": {"spearman": spearman, "dpq16": dpq},
    });
    Ok((value, row))
}

fn layout_name(layout: Layout) -> String {
    format!("{layout:?}").to_lowercase()
}

pub fn run(args: &GridArgs) -> Result<()> {
    let mut library = args.library.load()?;
    if let (Some(path), Some(branch)) = (&args.taxonomy, &args.branch) {
        library = branch_of(&library, path, branch)?;
    }
    let cells = args.rows.saturating_mul(args.cols);
    if args.rows == 0 || args.cols == 0 {
        bail!("--rows and --cols must be at least 1");
    }
    if cells > library.len() {
        let side = (library.len() as f64).sqrt().floor().max(1.0) as usize;
        bail!(
            "a {}x{} grid has {cells} cells but the items to lay out are {}: choose at most {} \
             cells (e.g. --rows {side} --cols {side})",
            args.rows,
            args.cols,
            library.len(),
            library.len()
        );
    }
    let bar = stage_bar(args.library.quiet);
    bar.set_message(match args.layout {
        Layout::Balanced => "SOM + Algorithms 3-4",
        Layout::Som => "SOM",
        Layout::Isomatch => "Isomap + assignment",
        Layout::Random => "random layout",
    });
    let labels = library.labels();
    let start = std::time::Instant::now();
    let layout = place(args.layout, &library, args)?;
    let seconds = start.elapsed().as_secs_f64();
    bar.set_message("quality");
    let (measured, row) = measure(&layout, &library, args.seed)?;
    let mut comparison = vec![(
        layout_name(args.layout),
        Ok((measured.clone(), row)),
        seconds,
    )];
    if args.compare {
        for other in Layout::value_variants()
            .iter()
            .filter(|&&l| l != args.layout)
        {
            bar.set_message(format!("comparison: {}", layout_name(*other)));
            let start = std::time::Instant::now();
            let placed = place(*other, &library, args);
            let seconds = start.elapsed().as_secs_f64();
            let result = placed.and_then(|g| measure(&g, &library, args.seed));
            comparison.push((layout_name(*other), result, seconds));
        }
    }
    bar.finish_and_clear();
    let item_labels: Vec<String> = labels
        .iter()
        .map(|&l| library.label_names()[l as usize].clone())
        .collect();
    let mut value = serde_json::to_value(layout.export(library.ids(), &item_labels)?)?;
    value["layout"] = json!(layout_name(args.layout));
    value["items"] = json!(library.len());
    value["cost"] = measured["cost"].clone();
    value["quality"] = measured["quality"].clone();
    if args.compare {
        value["comparison"] = comparison
            .iter()
            .map(|(name, result, seconds)| match result {
                Ok((m, _)) => json!({"layout": name, "seconds": seconds, "cost": m["cost"], "quality": m["quality"]}),
                Err(e) => json!({"layout": name, "seconds": seconds, "error": format!("{e:#}")}),
            })
            .collect();
    }
    // The comparison table is what --compare asks for: printed even with --quiet.
    if !args.library.quiet || args.compare {
        eprintln!("{} items on {}x{}:", library.len(), args.rows, args.cols);
        eprintln!(
            "{:<9} {:>8} {:>6} {:>6} {:>9} {:>8} {:>8} {:>6}",
            "layout", "seconds", "empty", "multi", "imbalance", "eq. 6.1", "Spearman", "DPQ16"
        );
        for (name, result, seconds) in &comparison {
            match result {
                Ok((_, row)) => eprintln!("{name:<9} {seconds:>8.3} {row}"),
                Err(e) => eprintln!("{name:<9} {seconds:>8.3} not laid out: {e:#}"),
            }
        }
    }
    let Some(out) = &args.out else {
        outln!("{}", serde_json::to_string_pretty(&value)?)?;
        return Ok(());
    };
    super::write_json(out, &value)?;
    if args.library.items.is_empty() {
        eprintln!("no --items given: no contact sheet");
        return Ok(());
    }
    write_sheet(args, &library, &layout, out)
}

/// The contact sheet: each node's shown item, framed when the node hides more.
fn write_sheet(
    args: &GridArgs,
    library: &StyleLibrary,
    layout: &Grid,
    out: &std::path::Path,
) -> Result<()> {
    let mut rows: Vec<Vec<Option<Cell>>> = (0..layout.rows)
        .map(|_| (0..layout.cols).map(|_| None).collect())
        .collect();
    for node in &layout.nodes {
        if let Some(i) = node.shown {
            rows[node.row][node.col] = Some(Cell {
                id: &library.ids()[i],
                framed: !node.hidden.is_empty(),
            });
        }
    }
    let ids: Vec<&str> = distinct(rows.iter().flatten().flatten().map(|c| c.id));
    let size = (2048 / layout.cols.max(layout.rows) as u32).clamp(16, 96);
    let thumbs = Thumbnails::render(&args.library.items, &ids, size, args.library.quiet)?;
    let image = sheet::grid(&thumbs, &rows, layout.cols);
    sheet::save(&image, &sheet_path(out), thumbs.missing, args.library.quiet)
}

/// The members of the representative style `branch` of the taxonomy JSON at `path`.
fn branch_of(library: &StyleLibrary, path: &std::path::Path, branch: &str) -> Result<StyleLibrary> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let taxonomy: Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let reps = taxonomy["representatives"]
        .as_array()
        .with_context(|| format!("{}: no `representatives` (not a taxonomy)", path.display()))?;
    let Some(rep) = reps.iter().find(|r| r["id"] == branch) else {
        let known: Vec<&str> = reps
            .iter()
            .filter_map(|r| r["id"].as_str())
            .take(10)
            .collect();
        bail!(
            "{}: no representative style `{branch}`; its representatives include {known:?}",
            path.display()
        );
    };
    let index: std::collections::HashMap<&str, usize> = library
        .ids()
        .iter()
        .enumerate()
        .map(|(i, id)| (id.as_str(), i))
        .collect();
    let mut keep = Vec::new();
    for m in rep["members"].as_array().into_iter().flatten() {
        let id = m.as_str().unwrap_or_default();
        match index.get(id) {
            Some(&i) => keep.push(i),
            None => bail!(
                "{}: member `{id}` of `{branch}` is not among the items (another library, or other --labels?)",
                path.display()
            ),
        }
    }
    Ok(library.subset(&keep)?)
}
