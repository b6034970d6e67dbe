//! `learner map`: the style map of §5.7.1 (t-SNE of the learned style space) as JSON
//! (`{"points": [{"id", "x", "y", "label"}, …]}`), a contact sheet, and with `--html DIR` a
//! static page to zoom, pan and search.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use learner::explore::map::{MapParams, style_map};
use learner::explore::{TsneMethod, TsneParams};
use serde_json::json;

use super::html::{self, PagePoint};
use super::library::{LibraryArgs, sheet_path};
use super::sheet::{self, Thumbnails};
use super::taxonomy::{distinct, stage_bar};

#[derive(Debug, Args)]
pub struct MapArgs {
    #[command(flatten)]
    pub library: LibraryArgs,
    /// Representatives per label (k-means in the style space; 100 per category in the paper).
    #[arg(long, default_value_t = 100, conflicts_with = "all")]
    pub per_label: usize,
    /// Map every item instead of representatives (up to 200,000).
    #[arg(long)]
    pub all: bool,
    /// t-SNE perplexity.
    #[arg(long, default_value_t = TsneParams::default().perplexity)]
    pub perplexity: f64,
    /// t-SNE iterations (the first 250 with early exaggeration).
    #[arg(long, default_value_t = TsneParams::default().n_iter)]
    pub iterations: usize,
    /// Exact gradients instead of Barnes–Hut (slow beyond a few thousand points).
    #[arg(long)]
    pub exact: bool,
    /// Seed of the representatives and the t-SNE.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Write the JSON here, and the contact sheet beside it (`.png`); without it the JSON goes
    /// to stdout.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also write a static page of the map (thumbnails, zoom, pan, search) into this folder.
    #[arg(long, requires = "items")]
    pub html: Option<PathBuf>,
}

/// Side of the contact sheet, and of its thumbnails.
const SHEET_SIDE: u32 = 2560;
const THUMB: u32 = 64;

pub fn run(args: &MapArgs) -> Result<()> {
    let library = args.library.load()?;
    let params = MapParams {
        per_label: (!args.all).then_some(args.per_label),
        tsne: TsneParams {
            perplexity: args.perplexity,
            n_iter: args.iterations,
            early_exaggeration_iter: TsneParams::default()
                .early_exaggeration_iter
                .min(args.iterations),
            method: if args.exact {
                TsneMethod::Exact
            } else {
                TsneMethod::Auto
            },
            seed: args.seed,
            ..TsneParams::default()
        },
    };
    let bar = stage_bar(args.library.quiet);
    bar.set_message("t-SNE");
    let map = style_map(&library, &params, &mut |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    let ids: Vec<&str> = map
        .items
        .iter()
        .map(|&i| library.ids()[i].as_str())
        .collect();
    let value = json!({
        "items_in_library": library.len(),
        "representatives_per_label": params.per_label,
        "perplexity": args.perplexity,
        "iterations": map.info.iterations,
        "kl_divergence": map.info.kl_divergence,
        "method": format!("{:?}", map.info.method),
        "seed": args.seed,
        "points": map.items.iter().zip(&map.positions).map(|(&i, p)| json!({
            "id": library.ids()[i],
            "x": p[0],
            "y": p[1],
            "label": library.label_names()[library.labels()[i] as usize],
        })).collect::<Vec<_>>(),
    });
    if !args.library.quiet {
        eprintln!(
            "mapped {} of {} items (KL divergence {:.3}, {:.1} s)",
            map.items.len(),
            library.len(),
            map.info.kl_divergence,
            map.info.affinity_seconds + map.info.init_seconds + map.info.optimise_seconds
        );
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
    let xy: Vec<(f32, f32)> = map.positions.iter().map(|p| (p[0], p[1])).collect();
    let cells = sheet::lattice(&xy, SHEET_SIDE, THUMB);
    let wanted: Vec<&str> = if args.html.is_some() {
        ids.clone()
    } else {
        distinct(cells.iter().map(|&(i, _, _)| ids[i]))
    };
    let thumbs = Thumbnails::render(&args.library.items, &wanted, THUMB, args.library.quiet)?;
    let image = sheet::scatter(&thumbs, &ids, &cells, SHEET_SIDE);
    sheet::save(&image, &sheet_path(out), thumbs.missing, args.library.quiet)?;
    if let Some(dir) = &args.html {
        let points: Vec<PagePoint> = map
            .items
            .iter()
            .zip(&map.positions)
            .map(|(&i, p)| PagePoint {
                id: &library.ids()[i],
                label: library.labels()[i],
                x: p[0],
                y: p[1],
            })
            .collect();
        html::write(dir, &points, library.label_names(), &thumbs)?;
        if !args.library.quiet {
            eprintln!("wrote {}/index.html", dir.display());
        }
    }
    Ok(())
}
