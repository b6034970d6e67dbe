//! `decompose`: intrinsic images from the command line. A thin layer over the library: parses
//! arguments into validated parameters, draws progress, writes files.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};

use decompose::clustering::{self, ClusteringParams};
use decompose::color_retinex::{self, ColorRetinexParams};
use decompose::edit::{self, Curve, StyliseParams};
use decompose::io::{self, Depth, Encoding, LoadOptions};
use decompose::metrics::{self, Scores};
use decompose::retinex::{self, RetinexParams, Strokes};
use decompose::{Decomposition, Image, Labels, Mask, Progress, plot};

#[derive(Parser)]
#[command(
    version,
    about = "Intrinsic images: reflectance and shading from one photograph"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Decompose one image and write reflectance, shading, cluster map, scatter plot, stats.
    Image(ImageArgs),
    /// Evaluate every method on the MIT intrinsic images (LMSE and scale-invariant MSE).
    Eval(EvalArgs),
    /// Editing applications on a decomposition.
    #[command(subcommand)]
    Edit(EditCommand),
    /// WHDR of a decomposition against IIW judgements (Bell et al. 2014).
    Whdr(WhdrArgs),
    /// Time the clustering method at 640x480 (k=10) and 1024x1024 (k=30); print a table.
    Bench(BenchArgs),
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum Method {
    Clustering,
    Retinex,
    ColorRetinex,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Clustering => "clustering",
            Method::Retinex => "retinex",
            Method::ColorRetinex => "color-retinex",
        }
    }
}

#[derive(Args, Clone)]
struct DecomposeArgs {
    /// Method.
    #[arg(long, value_enum, default_value = "clustering")]
    method: Method,
    /// The input is already linear (RAW-derived); otherwise 8/16-bit files are sRGB-decoded.
    #[arg(long)]
    linear: bool,
    /// Mask image: decompose only where it is white.
    #[arg(long)]
    mask: Option<PathBuf>,
    /// k-means segments k (clustering).
    #[arg(long, default_value_t = 10)]
    k: usize,
    /// Random seed (clustering).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Constant-albedo stroke masks (retinex), repeatable.
    #[arg(long = "albedo-stroke")]
    albedo_strokes: Vec<PathBuf>,
    /// Constant-shading stroke masks (retinex), repeatable.
    #[arg(long = "shading-stroke")]
    shading_strokes: Vec<PathBuf>,
    /// Regions using the local chroma threshold T' (retinex), repeatable.
    #[arg(long = "local-threshold")]
    local_threshold: Vec<PathBuf>,
}

#[derive(Args)]
struct ImageArgs {
    /// Input image (PNG, JPEG or TIFF; 8 or 16 bits, or 32-bit float TIFF).
    input: PathBuf,
    /// Output directory (created).
    #[arg(long)]
    out_dir: PathBuf,
    #[command(flatten)]
    opts: DecomposeArgs,
    /// Bits per sample of reflectance.png and shading.png.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u8).range(8..=16))]
    depth: u8,
    /// Write linear values instead of display gamma (sRGB), and also reflectance.tiff and
    /// shading.tiff: 32-bit float, unclipped and unscaled, so that their product is the input.
    #[arg(long)]
    linear_output: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args)]
struct EvalArgs {
    /// Directory with one folder per object holding original/diffuse/reflectance/shading/mask.
    #[arg(long)]
    mit: PathBuf,
    /// Write the numbers as JSON keyed by method.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Use original.png (with specularities) as input instead of diffuse.png.
    #[arg(long)]
    original: bool,
    /// Methods to run (default: all).
    #[arg(long, value_enum, value_delimiter = ',')]
    methods: Vec<Method>,
}

#[derive(Args)]
struct EditIo {
    /// Input image.
    input: PathBuf,
    /// Output image (display gamma PNG).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    opts: DecomposeArgs,
}

#[derive(Subcommand)]
enum EditCommand {
    /// Rotate the reflectance hue / scale its saturation (inside --region or everywhere).
    Recolour {
        #[command(flatten)]
        io: EditIo,
        /// Region to recolour (mask image).
        #[arg(long)]
        region: Option<PathBuf>,
        /// Hue rotation in degrees.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        hue: f32,
        /// Saturation factor.
        #[arg(long, default_value_t = 1.0)]
        saturation: f32,
    },
    /// Replace the reflectance inside --region by a tiled texture, keeping the shading.
    Retexture {
        #[command(flatten)]
        io: EditIo,
        /// Region (mask image).
        #[arg(long)]
        region: PathBuf,
        /// Texture image.
        #[arg(long)]
        texture: PathBuf,
    },
    /// Remap the shading through a curve of control points "x:y,x:y,..." in [0, 1].
    Relight {
        #[command(flatten)]
        io: EditIo,
        /// Control points, e.g. "0:0,0.5:0.8,1:1".
        #[arg(long)]
        curve: String,
    },
    /// Histogram-match the reflectance to that of a source image.
    Transfer {
        #[command(flatten)]
        io: EditIo,
        /// Source image (decomposed with the same method).
        #[arg(long)]
        source: PathBuf,
    },
    /// Saturation change, flattened shading and an edge layer.
    Stylise {
        #[command(flatten)]
        io: EditIo,
        /// Saturation factor.
        #[arg(long, default_value_t = 1.4)]
        saturation: f32,
        /// Shading flattening in [0, 1].
        #[arg(long, default_value_t = 0.6)]
        flatten: f32,
        /// Edge darkening in [0, 1].
        #[arg(long, default_value_t = 0.8)]
        edges: f32,
    },
    /// Segment by reflectance clusters; writes a false-colour label map.
    Segment {
        #[command(flatten)]
        io: EditIo,
        /// Number of reflectance segments.
        #[arg(long, default_value_t = 6)]
        segments: usize,
    },
}

#[derive(Args)]
struct WhdrArgs {
    /// The IIW photo.
    input: PathBuf,
    /// Its judgement JSON.
    judgements: PathBuf,
    #[command(flatten)]
    opts: DecomposeArgs,
    /// Equality threshold δ.
    #[arg(long, default_value_t = 0.10)]
    delta: f64,
}

#[derive(Args)]
struct BenchArgs {
    /// Repetitions per case (the minimum is reported).
    #[arg(long, default_value_t = 3)]
    repeat: usize,
}

fn main() -> std::process::ExitCode {
    // One line with the whole cause chain; no backtrace noise even when RUST_BACKTRACE is set.
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Image(a) => run_image(a),
        Command::Eval(a) => run_eval(a),
        Command::Edit(e) => run_edit(e),
        Command::Whdr(a) => run_whdr(a),
        Command::Bench(a) => run_bench(a),
    }
}

/// Writes to stdout, turning a closed pipe into an error instead of a panic.
fn out(text: &str) -> Result<()> {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
        .context("writing to standard output")
}

fn bar(quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(100);
    if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos:>3}% {msg}") {
        pb.set_style(style);
    }
    pb
}

struct Run {
    decomposition: Decomposition,
    clusters: Option<Labels>,
    stats: serde_json::Value,
}

fn load_input(path: &Path, linear: bool) -> Result<Image> {
    io::load_rgb(
        path,
        LoadOptions {
            linear,
            ..Default::default()
        },
    )
    .with_context(|| format!("reading {}", path.display()))
}

fn load_masks(paths: &[PathBuf]) -> Result<Vec<Mask>> {
    paths
        .iter()
        .map(|p| io::load_mask(p).with_context(|| format!("reading mask {}", p.display())))
        .collect()
}

fn run_method(
    input: &Image,
    mask: Option<&Mask>,
    o: &DecomposeArgs,
    pb: &ProgressBar,
) -> Result<Run> {
    let mut report = |p: Progress| {
        pb.set_position((p.fraction * 100.0) as u64);
        pb.set_message(p.stage);
    };
    let t = Instant::now();
    let run = match o.method {
        Method::Clustering => {
            let params = ClusteringParams {
                k: o.k,
                seed: o.seed,
                ..Default::default()
            };
            let out = clustering::decompose(input, mask, &params, &mut report)?;
            Run {
                decomposition: out.decomposition,
                clusters: Some(out.clusters),
                stats: serde_json::to_value(&out.info)?,
            }
        }
        Method::Retinex => {
            let strokes = Strokes {
                constant_albedo: load_masks(&o.albedo_strokes)?,
                constant_shading: load_masks(&o.shading_strokes)?,
                local_threshold: load_masks(&o.local_threshold)?,
            };
            let (d, info) = retinex::decompose(
                input,
                mask,
                &strokes,
                &RetinexParams::default(),
                &mut report,
            )?;
            Run {
                decomposition: d,
                clusters: None,
                stats: serde_json::to_value(&info)?,
            }
        }
        Method::ColorRetinex => {
            let (d, info) =
                color_retinex::decompose(input, mask, &ColorRetinexParams::default(), &mut report)?;
            Run {
                decomposition: d,
                clusters: None,
                stats: serde_json::json!({ "solver": info }),
            }
        }
    };
    let mut run = run;
    run.stats["method"] = o.method.name().into();
    run.stats["wall_ms"] = (t.elapsed().as_secs_f64() * 1e3).into();
    Ok(run)
}

fn run_image(a: ImageArgs) -> Result<()> {
    let input = load_input(&a.input, a.opts.linear)?;
    let mask = a
        .opts
        .mask
        .as_ref()
        .map(|p| io::load_mask(p).with_context(|| format!("reading mask {}", p.display())))
        .transpose()?;
    if let (Some(m), Some(p)) = (&mask, &a.opts.mask) {
        input
            .check_dims(m.dims())
            .with_context(|| format!("mask {} does not fit the image", p.display()))?;
    }
    let pb = bar(a.quiet);
    let run = run_method(&input, mask.as_ref(), &a.opts, &pb)?;
    pb.finish_and_clear();
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    let enc = if a.linear_output {
        Encoding::Linear
    } else {
        Encoding::Srgb
    };
    let depth = if a.depth > 8 {
        Depth::Sixteen
    } else {
        Depth::Eight
    };
    let d = &run.decomposition;
    io::save(
        a.out_dir.join("reflectance.png"),
        &d.reflectance,
        enc,
        depth,
    )?;
    // Shading is written relative to its maximum inside the mask so it fits the file's range.
    // Outside the mask the shading is black in the file (the library keeps 1 there).
    let full = Mask::full(input.width(), input.height());
    let m = mask.as_ref().unwrap_or(&full);
    let mut shading = d.shading.clone();
    for i in 0..shading.len() {
        if !m.at(i) {
            shading.px_mut(i)[0] = 0.0;
        }
    }
    let smax = shading.max().max(f32::MIN_POSITIVE);
    io::save(
        a.out_dir.join("shading.png"),
        &shading.map(|v| v / smax),
        enc,
        depth,
    )?;
    // The PNGs clip the brightest 0.5% of reflectance values (the decomposition's scale puts
    // its 99.5th percentile at 1) and scale the shading to its maximum; the float TIFFs keep
    // every value, so reflectance.tiff × shading.tiff = the linear input inside the mask.
    if a.linear_output {
        io::save_float_tiff(a.out_dir.join("reflectance.tiff"), &d.reflectance)?;
        io::save_float_tiff(a.out_dir.join("shading.tiff"), &d.shading)?;
    }
    if let Some(c) = &run.clusters {
        io::save_rgb8(
            a.out_dir.join("clusters.png"),
            c.width,
            c.height,
            c.false_colour(),
        )?;
    }
    let size = 512;
    io::save_rgb8(
        a.out_dir.join("scatter.png"),
        size,
        size,
        plot::ab_scatter(&input, m, run.clusters.as_ref(), size),
    )?;
    let mut stats = run.stats;
    stats["input"] = a.input.display().to_string().into();
    stats["width"] = input.width().into();
    stats["height"] = input.height().into();
    stats["shading_scale"] = smax.into();
    stats["output_encoding"] = if a.linear_output { "linear" } else { "srgb" }.into();
    std::fs::write(
        a.out_dir.join("stats.json"),
        serde_json::to_string_pretty(&stats)?,
    )?;
    Ok(())
}

#[derive(serde::Serialize, Default)]
struct MethodResult {
    objects: BTreeMap<String, Scores>,
    mean: Scores,
    seconds: BTreeMap<String, f64>,
}

fn mean(scores: &BTreeMap<String, Scores>) -> Scores {
    let n = scores.len().max(1) as f64;
    let mut m = Scores::default();
    for s in scores.values() {
        m.lmse += s.lmse / n;
        m.lmse_shading += s.lmse_shading / n;
        m.lmse_reflectance += s.lmse_reflectance / n;
        m.si_mse += s.si_mse / n;
        m.si_mse_shading += s.si_mse_shading / n;
        m.si_mse_reflectance += s.si_mse_reflectance / n;
    }
    m
}

fn run_eval(a: EvalArgs) -> Result<()> {
    let methods = if a.methods.is_empty() {
        vec![Method::Clustering, Method::Retinex, Method::ColorRetinex]
    } else {
        a.methods.clone()
    };
    let mut objects: Vec<PathBuf> = std::fs::read_dir(&a.mit)
        .with_context(|| format!("reading {}", a.mit.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("reflectance.png").exists())
        .collect();
    objects.sort();
    if objects.is_empty() {
        bail!("no MIT object folders under {}", a.mit.display());
    }
    let lin = LoadOptions {
        linear: true,
        ..Default::default()
    };
    let mut results: BTreeMap<&'static str, MethodResult> = BTreeMap::new();
    let pb = bar(false);
    pb.set_length((objects.len() * methods.len()) as u64);
    for obj in &objects {
        let name = obj
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let input_name = if a.original {
            "original.png"
        } else {
            "diffuse.png"
        };
        let input = io::load_rgb(obj.join(input_name), lin)?;
        let gt_r = io::load_rgb(obj.join("reflectance.png"), lin)?;
        let gt_s = io::load_gray(obj.join("shading.png"), lin)?;
        let mask = io::load_mask(obj.join("mask.png"))?;
        for &m in &methods {
            pb.set_message(format!("{name} {}", m.name()));
            let o = DecomposeArgs {
                method: m,
                linear: true,
                mask: None,
                k: 10,
                seed: 0,
                albedo_strokes: vec![],
                shading_strokes: vec![],
                local_threshold: vec![],
            };
            let t = Instant::now();
            let run = run_method(&input, Some(&mask), &o, &ProgressBar::hidden())
                .with_context(|| format!("{name}: {}", m.name()))?;
            let secs = t.elapsed().as_secs_f64();
            let d = &run.decomposition;
            let s = metrics::score(&d.reflectance, &d.shading, &gt_r, &gt_s, &mask)?;
            let r = results.entry(m.name()).or_default();
            r.objects.insert(name.clone(), s);
            r.seconds.insert(name.clone(), secs);
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    for r in results.values_mut() {
        r.mean = mean(&r.objects);
    }
    // Table: LMSE per object and method, then si-MSE. Built as a string and written once, so
    // a closed stdout (e.g. `| head`) is an error message, not a panic.
    use std::fmt::Write as _;
    let names: Vec<&str> = methods.iter().map(|m| m.name()).collect();
    let mut table = String::new();
    for (title, pick) in [
        ("LMSE (Grosse et al., 20x20 windows, stride 10)", 0),
        ("scale-invariant MSE (whole image)", 1),
    ] {
        writeln!(table, "\n{title}")?;
        write!(table, "{:<12}", "object")?;
        for n in &names {
            write!(table, " {n:>14}")?;
        }
        writeln!(table)?;
        let mut row = |label: &str, get: &dyn Fn(&MethodResult) -> Option<Scores>| {
            let mut line = format!("{label:<12}");
            for n in &names {
                let v = results
                    .get(n)
                    .and_then(get)
                    .map_or(f64::NAN, |s| if pick == 0 { s.lmse } else { s.si_mse });
                line += &format!(" {v:>14.5}");
            }
            table += &line;
            table.push('\n');
        };
        for obj in results
            .values()
            .next()
            .map(|r| r.objects.keys().cloned().collect::<Vec<_>>())
            .unwrap_or_default()
        {
            row(&obj, &|r: &MethodResult| r.objects.get(&obj).cloned());
        }
        row("mean", &|r: &MethodResult| Some(r.mean.clone()));
    }
    out(&table)?;
    if let Some(p) = a.json {
        std::fs::write(&p, serde_json::to_string_pretty(&results)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

fn decompose_file(io_args: &EditIo) -> Result<(Image, Run)> {
    let input = load_input(&io_args.input, io_args.opts.linear)?;
    let mask = io_args.opts.mask.as_ref().map(io::load_mask).transpose()?;
    let run = run_method(&input, mask.as_ref(), &io_args.opts, &ProgressBar::hidden())?;
    Ok((input, run))
}

fn parse_curve(s: &str) -> Result<Curve> {
    let mut pts = Vec::new();
    for item in s.split(',') {
        let (x, y) = item
            .split_once(':')
            .with_context(|| format!("curve point {item:?} is not x:y"))?;
        pts.push((x.trim().parse::<f32>()?, y.trim().parse::<f32>()?));
    }
    Ok(Curve::new(&pts)?)
}

fn save_edit(path: &Path, img: &Image) -> Result<()> {
    // Edits can brighten beyond 1; keep the input's range by clamping at write time.
    io::save(path, img, Encoding::Srgb, Depth::Eight)
        .with_context(|| format!("writing {}", path.display()))
}

fn run_edit(e: EditCommand) -> Result<()> {
    match e {
        EditCommand::Recolour {
            io: a,
            region,
            hue,
            saturation,
        } => {
            let (_, run) = decompose_file(&a)?;
            let region = region.map(io::load_mask).transpose()?;
            let out = edit::recolour(&run.decomposition, region.as_ref(), hue, saturation)?;
            save_edit(&a.out, &out)
        }
        EditCommand::Retexture {
            io: a,
            region,
            texture,
        } => {
            let (_, run) = decompose_file(&a)?;
            let region = io::load_mask(region)?;
            let tex = load_input(&texture, false)?;
            save_edit(&a.out, &edit::retexture(&run.decomposition, &region, &tex)?)
        }
        EditCommand::Relight { io: a, curve } => {
            let curve = parse_curve(&curve)?;
            let (_, run) = decompose_file(&a)?;
            save_edit(&a.out, &edit::relight(&run.decomposition, &curve))
        }
        EditCommand::Transfer { io: a, source } => {
            let (_, run) = decompose_file(&a)?;
            let src = load_input(&source, a.opts.linear)?;
            let src_run = run_method(&src, None, &a.opts, &ProgressBar::hidden())?;
            let out = edit::transfer(&run.decomposition, &src_run.decomposition.reflectance)?;
            save_edit(&a.out, &out)
        }
        EditCommand::Stylise {
            io: a,
            saturation,
            flatten,
            edges,
        } => {
            let (_, run) = decompose_file(&a)?;
            let p = StyliseParams {
                saturation,
                flatten,
                edge_strength: edges,
                ..Default::default()
            };
            save_edit(&a.out, &edit::stylise(&run.decomposition, &p)?)
        }
        EditCommand::Segment { io: a, segments } => {
            let (_, run) = decompose_file(&a)?;
            let mask = a.opts.mask.as_ref().map(io::load_mask).transpose()?;
            let l = edit::segment(
                &run.decomposition.reflectance,
                mask.as_ref(),
                segments,
                a.opts.seed,
            )?;
            io::save_rgb8(&a.out, l.width, l.height, l.false_colour())?;
            Ok(())
        }
    }
}

fn run_whdr(a: WhdrArgs) -> Result<()> {
    let input = load_input(&a.input, a.opts.linear)?;
    let run = run_method(&input, None, &a.opts, &ProgressBar::hidden())?;
    let json = std::fs::read_to_string(&a.judgements)
        .with_context(|| format!("reading {}", a.judgements.display()))?;
    let v = metrics::whdr(&run.decomposition.reflectance, &json, a.delta)?;
    out(&format!("WHDR({:.2}) = {v:.4}\n", a.delta))?;
    Ok(())
}

fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn run_bench(a: BenchArgs) -> Result<()> {
    let astronaut = io::decode_rgb(
        include_bytes!("../../fixtures/photos/astronaut.jpg"),
        Path::new("astronaut.jpg"),
        LoadOptions::default(),
    )?;
    let coffee = io::decode_rgb(
        include_bytes!("../../fixtures/photos/coffee.jpg"),
        Path::new("coffee.jpg"),
        LoadOptions::default(),
    )?;
    let chelsea = io::decode_rgb(
        include_bytes!("../../fixtures/photos/chelsea.jpg"),
        Path::new("chelsea.jpg"),
        LoadOptions::default(),
    )?;
    // A busier 1024x1024 image: the three photos and a mirrored astronaut as 512x512 quadrants.
    let quads = [
        astronaut.resize(512, 512),
        coffee.resize(512, 512),
        chelsea.resize(512, 512),
        astronaut.resize(512, 512),
    ];
    let mosaic = Image::from_fn(1024, 1024, |x, y| {
        let q = &quads[(y / 512 * 2 + x / 512) as usize];
        let (qx, qy) = if y >= 512 && x >= 512 {
            (511 - x % 512, y % 512)
        } else {
            (x % 512, y % 512)
        };
        let p = q.get(qx, qy);
        [p[0], p[1], p[2]]
    });
    let cases = [
        ("coffee 640x480", coffee.resize(640, 480), 10usize, 0.3),
        ("astronaut 1024x1024", astronaut.resize(1024, 1024), 30, 2.0),
        ("mosaic 1024x1024", mosaic, 30, 2.0),
    ];
    out(&format!(
        "{:<22} {:>4} {:>9} {:>9} {:>10} {:>10} {:>8} {:>11}\n",
        "case", "k", "clusters", "eqs", "best (s)", "target (s)", "ratio", "peak RSS MiB"
    ))?;
    for (name, img, k, target) in cases {
        let params = ClusteringParams {
            k,
            ..Default::default()
        };
        // Reset the peak-RSS high-water mark (Linux ≥ 4.0) so each case reports its own peak.
        let _ = std::fs::write("/proc/self/clear_refs", "5");
        let mut best = f64::INFINITY;
        let mut info = None;
        for _ in 0..a.repeat.max(1) {
            let t = Instant::now();
            let out = clustering::decompose(&img, None, &params, &mut |_| {})?;
            best = best.min(t.elapsed().as_secs_f64());
            info = Some(out.info);
        }
        let info = info.unwrap_or_default();
        let eqs = info.equations.boundary + info.equations.reflectance;
        out(&format!(
            "{:<22} {:>4} {:>9} {:>9} {:>10.3} {:>10.1} {:>8.2} {:>11.0}\n",
            name,
            k,
            info.clusters,
            eqs,
            best,
            target,
            best / target,
            peak_rss_mib().unwrap_or(f64::NAN)
        ))?;
    }
    Ok(())
}
