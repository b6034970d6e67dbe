//! The metric subcommands: `simulate`, `split`, `triplets`, `train`, `eval`, `rank`, `report`
//! and the metric part of `bench`. Each is a clap `Args` struct plus a `run_*` function; the
//! library does the work, this file only parses, reads/writes files and draws progress.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use learner::eval::rank::RankScores;
use learner::eval::report::{learning_curve, write_report};
use learner::eval::triplets::{BootstrapParams, Estimate, MethodScores};
use learner::eval::{EvalReport, RankReport, evaluate, rank};
use learner::metric::Model;
use learner::metric::cv::{CvParams, CvReport, cross_validate, default_grid};
use learner::metric::model::{fit_scaling, standardise};
use learner::metric::objective::{DEFAULT_SMOOTHING, TripletObjective};
use learner::metric::simulate::{SimulationParams, simulate};
use learner::metric::solver::{LbfgsParams, SolverInfo, SolverKind, minimise};
use learner::metric::train::{LambdaChoice, TrainParams, TrainProgress, fit_uniform_scale, train};
use learner::table::{FeatureTable, read_features, read_labels, write_features_to, write_labels};
use learner::triplets::{
    TripletRecord, TripletSet, generate_labelled, read_triplets, split_labels, write_triplets,
};

fn bar(len: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{spinner} {prefix} [{bar:30}] {pos}/{len} {msg}")
            .expect("static template")
            .progress_chars("=> "),
    );
    pb.set_prefix(what.to_owned());
    pb
}

fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

/// `learner simulate`: a simulated crowd as files (features, triplets with workers, truth).
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Output folder (features.csv, triplets.csv, fresh.csv, truth.json).
    #[arg(long)]
    pub out: PathBuf,
    /// Answered triplets.
    #[arg(long, default_value_t = 25_000)]
    pub n: usize,
    /// Number of features.
    #[arg(long, default_value_t = 40)]
    pub dim: usize,
    /// Informative features.
    #[arg(long, default_value_t = 6)]
    pub support: usize,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// Runs `learner simulate`.
pub fn run_simulate(a: &SimulateArgs) -> Result<()> {
    let sim = simulate(&SimulationParams {
        triplets: a.n,
        dim: a.dim,
        support: a.support,
        seed: a.seed,
        ..SimulationParams::default()
    })?;
    std::fs::create_dir_all(&a.out)?;
    let f = a.out.join("features.csv");
    write_features_to(&sim.table, std::fs::File::create(&f)?, &f)?;
    let ids = sim.table.ids();
    for (name, rows) in [
        ("triplets.csv", sim.triplets.clone()),
        ("fresh.csv", sim.fresh(a.n, a.seed + 1)),
    ] {
        let mut w = csv::Writer::from_path(a.out.join(name))?;
        w.write_record(["a", "b", "c", "q", "worker", "tuple_id"])?;
        for t in rows {
            w.write_record([
                ids[t.a as usize].as_str(),
                &ids[t.b as usize],
                &ids[t.c as usize],
                if t.q { "1" } else { "0" },
                &format!("w{}", t.worker.unwrap_or(0)),
                &format!("t{}", t.tuple),
            ])?;
        }
        w.flush()?;
    }
    write_json(&a.out.join("truth.json"), &sim.true_weights)?;
    outln!(
        "wrote {} (features, triplets, fresh, truth)",
        a.out.display()
    )?;
    Ok(())
}

/// `learner split`: hold out styles and concepts.
#[derive(Debug, Args)]
pub struct SplitArgs {
    /// Labels CSV (`file,style,concept,...`).
    #[arg(long)]
    pub labels: PathBuf,
    /// Styles to hold out, comma-separated.
    #[arg(long, value_delimiter = ',', required = true)]
    pub test_styles: Vec<String>,
    /// Fraction of concepts to hold out.
    #[arg(long, default_value_t = 0.3)]
    pub concept_fraction: f64,
    /// Seed for the concept draw.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Training labels output.
    #[arg(long)]
    pub train_out: PathBuf,
    /// Test labels output.
    #[arg(long)]
    pub test_out: PathBuf,
}

/// Runs `learner split`.
pub fn run_split(a: &SplitArgs) -> Result<()> {
    let labels = read_labels(&a.labels)?;
    let s = split_labels(&labels, &a.test_styles, a.concept_fraction, a.seed)?;
    write_labels(&s.train, &a.train_out)?;
    write_labels(&s.test, &a.test_out)?;
    outln!(
        "train {} items, test {} items, dropped {} (one of style/concept held out)",
        s.train.len(),
        s.test.len(),
        s.dropped
    )?;
    Ok(())
}

/// `learner triplets`: labelled-group triplets (same style closer).
#[derive(Debug, Args)]
pub struct TripletsArgs {
    /// Labels CSV (`file,style,...`).
    #[arg(long)]
    pub labels: PathBuf,
    /// Number of triplets.
    #[arg(long)]
    pub n: usize,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Only use labelled ids present in this features file.
    #[arg(long)]
    pub features: Option<PathBuf>,
    /// Output CSV.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `learner triplets`.
pub fn run_triplets(a: &TripletsArgs) -> Result<()> {
    let mut labels = read_labels(&a.labels)?;
    if let Some(f) = &a.features {
        let table = read_features(f)?;
        let before = labels.len();
        labels.retain(|l| table.index_of(&l.id).is_some());
        eprintln!("{} of {before} labelled items have features", labels.len());
    }
    let t: Vec<TripletRecord> = generate_labelled(&labels, a.n, a.seed)?;
    write_triplets(&t, &a.out)?;
    outln!("wrote {} triplets to {}", t.len(), a.out.display())?;
    Ok(())
}

/// `learner train`.
#[derive(Debug, Args)]
pub struct TrainArgs {
    /// Features CSV (`id,<names...>`).
    #[arg(long)]
    pub features: PathBuf,
    /// Triplets CSV (`a,b,c,q[,worker][,tuple_id]`).
    #[arg(long)]
    pub triplets: PathBuf,
    /// Output model.json.
    #[arg(long)]
    pub out: PathBuf,
    /// λ, or `auto` for cross-validation.
    #[arg(long, default_value = "auto")]
    pub lambda: String,
    /// Explicit λ grid for `auto` (comma-separated); default: 8 values, n·[1e-5, 1e-1].
    #[arg(long, value_delimiter = ',')]
    pub grid: Option<Vec<f64>>,
    /// `argmin` or `nlopt`.
    #[arg(long, default_value = "argmin")]
    pub solver: String,
    /// Cross-validation folds.
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Seed for folds.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Skip (and count) invalid triplet rows instead of failing.
    #[arg(long)]
    pub skip_invalid: bool,
}

/// Runs `learner train`.
pub fn run_train(a: &TrainArgs) -> Result<()> {
    let table = read_features(&a.features)?;
    let set = read_triplets(&a.triplets, &table, a.skip_invalid)?;
    if set.skipped > 0 {
        eprintln!(
            "skipped {} invalid rows, e.g. {}",
            set.skipped,
            set.skip_examples.join("; ")
        );
    }
    let lambda =
        if a.lambda == "auto" {
            LambdaChoice::Auto(a.grid.clone())
        } else {
            LambdaChoice::Fixed(a.lambda.parse().with_context(|| {
                format!("--lambda must be a number or `auto`, got `{}`", a.lambda)
            })?)
        };
    let params = TrainParams {
        lambda,
        folds: a.folds,
        seed: a.seed,
        solver: a.solver.parse()?,
        ..TrainParams::default()
    };
    let pb = bar(1, "train");
    let start = Instant::now();
    let model = train(&table, &set, &params, &mut |p| match p {
        TrainProgress::Cv { done, total } => {
            pb.set_length(total as u64 + 1);
            pb.set_position(done as u64);
            pb.set_message("cross-validation");
        }
        TrainProgress::Path { done, total } => {
            pb.set_message(format!("final fit: path {done}/{total}"))
        }
        TrainProgress::Final {
            iteration,
            objective,
        } => pb.set_message(format!(
            "final fit: iteration {iteration}, E = {objective:.4}"
        )),
    })?;
    pb.finish_and_clear();
    model.save(&a.out)?;
    outln!(
        "λ = {:.4}, {} of {} weights non-zero, objective {:.6} ({} iterations, {} evaluations, \
         converged: {}) in {:.2} s → {}",
        model.lambda,
        model.nonzero,
        model.weights.len(),
        model.solver.objective,
        model.solver.iterations,
        model.solver.evaluations,
        model.solver.converged,
        start.elapsed().as_secs_f64(),
        a.out.display()
    )?;
    if let Some(cv) = &model.cv {
        print_cv(cv)?;
    }
    Ok(())
}

/// The λ search: the curve with ±1 SE, which λ the rules picked, the uniform baseline, the
/// held-out agreement with intervals; warnings on stderr.
fn print_cv(cv: &CvReport) -> Result<()> {
    outln!(
        "{:>12} {:>19} {:>10} {:>9}",
        "λ",
        "log-loss ± SE",
        "accuracy",
        "non-zero"
    )?;
    for r in &cv.rows {
        let mut marks = Vec::new();
        if r.lambda == cv.chosen {
            marks.push("chosen");
        }
        if cv.minimum == Some(r.lambda) {
            marks.push("minimum");
        }
        if cv.one_se == Some(r.lambda) {
            marks.push("one-SE rule");
        }
        outln!(
            "{:>12.4} {:>10.5} ± {:<7.5} {:>10.4} {:>9.1}{}",
            r.lambda,
            r.log_loss,
            r.std_error,
            r.accuracy,
            r.nonzero,
            if marks.is_empty() {
                String::new()
            } else {
                format!("  ← {}", marks.join(", "))
            }
        )?;
    }
    if let Some(u) = &cv.uniform {
        outln!(
            "{:>12} {:>10.5} ± {:<7.5} {:>10.4} {:>9}",
            "uniform",
            u.log_loss,
            u.std_error,
            u.accuracy,
            "all"
        )?;
    }
    if let Some(a) = &cv.agreement {
        outln!(
            "held-out agreement ({}-fold, 95% intervals by bootstrap over {} {}s): learned {}, \
             uniform {}, difference {}{}",
            cv.folds,
            a.units,
            a.unit,
            est(&a.learned),
            est(&a.uniform),
            est(&a.difference),
            if a.learned_clearly_better() {
                ""
            } else {
                " (intervals overlap)"
            }
        )?;
    }
    for w in &cv.warnings {
        eprintln!("warning: {w}");
    }
    Ok(())
}

/// `learner eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// model.json.
    #[arg(long)]
    pub model: PathBuf,
    /// Features CSV.
    #[arg(long)]
    pub features: PathBuf,
    /// Test triplets CSV.
    #[arg(long)]
    pub triplets: PathBuf,
    /// Also write the report as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Bootstrap resamples.
    #[arg(long, default_value_t = 1000)]
    pub bootstrap: usize,
    /// Bootstrap seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Skip (and count) invalid triplet rows.
    #[arg(long)]
    pub skip_invalid: bool,
}

fn est(e: &Estimate) -> String {
    format!("{:.4} [{:.4}, {:.4}]", e.value, e.low, e.high)
}

fn print_eval(r: &EvalReport) -> Result<()> {
    outln!(
        "{:<10} {:<8} {:>28} {:>28} {:>7}",
        "metric",
        "labels",
        "accuracy [95% CI]",
        "perplexity [95% CI]",
        "n"
    )?;
    for (name, m) in [
        ("learned", &r.learned),
        ("uniform", &r.uniform),
        ("random", &r.random),
    ] {
        let m: &MethodScores = m;
        outln!(
            "{name:<10} {:<8} {:>28} {:>28} {:>7}",
            "raw",
            est(&m.raw.accuracy),
            est(&m.raw.perplexity),
            m.raw.n
        )?;
        if let Some(s) = &m.majority {
            outln!(
                "{name:<10} {:<8} {:>28} {:>28} {:>7}",
                "majority",
                est(&s.accuracy),
                est(&s.perplexity),
                s.n
            )?;
        }
    }
    if r.learned.ties_dropped > 0 {
        outln!("(majority: {} tied tuples dropped)", r.learned.ties_dropped)?;
    }
    Ok(())
}

/// Runs `learner eval`.
pub fn run_eval(a: &EvalArgs) -> Result<()> {
    let model = Model::load(&a.model)?;
    let table = read_features(&a.features)?;
    let set = read_triplets(&a.triplets, &table, a.skip_invalid)?;
    if set.skipped > 0 {
        eprintln!("skipped {} invalid rows", set.skipped);
    }
    let report = evaluate(
        &model,
        &table,
        &set.triplets,
        &BootstrapParams {
            resamples: a.bootstrap,
            seed: a.seed,
        },
    )?;
    print_eval(&report)?;
    if let Some(p) = &a.json {
        write_json(p, &report)?;
    }
    Ok(())
}

/// `learner rank`.
#[derive(Debug, Args)]
pub struct RankArgs {
    /// model.json.
    #[arg(long)]
    pub model: PathBuf,
    /// Features CSV.
    #[arg(long)]
    pub features: PathBuf,
    /// Labels CSV: items to rank and their styles.
    #[arg(long)]
    pub labels: PathBuf,
    /// Use at most this many (seeded random) queries.
    #[arg(long)]
    pub max_queries: Option<usize>,
    /// Seed for the query subset.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Also write the table as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

fn print_rank(r: &RankReport) -> Result<()> {
    let row = |name: &str, s: &RankScores| {
        outln!(
            "{name:<9} {:>6.3} {:>6.3} {:>6.3} {:>7.3} {:>8.3} {:>7.3} {:>8.3}",
            s.auc,
            s.map,
            s.mrr,
            s.prec_at_3,
            s.prec_at_10,
            s.ndcg_at_3,
            s.ndcg_at_10
        )
    };
    outln!(
        "{} items, {} styles, {} queries{}",
        r.items,
        r.styles,
        r.learned.queries,
        if r.missing > 0 {
            format!(" ({} labelled items without features ignored)", r.missing)
        } else {
            String::new()
        }
    )?;
    outln!(
        "{:<9} {:>6} {:>6} {:>6} {:>7} {:>8} {:>7} {:>8}",
        "metric",
        "AUC",
        "MAP",
        "MRR",
        "Prec@3",
        "Prec@10",
        "NDCG@3",
        "NDCG@10"
    )?;
    row("learned", &r.learned)?;
    row("uniform", &r.uniform)
}

/// Runs `learner rank`.
pub fn run_rank(a: &RankArgs) -> Result<()> {
    let model = Model::load(&a.model)?;
    let table = read_features(&a.features)?;
    let labels = read_labels(&a.labels)?;
    let report = rank(&model, &table, &labels, a.max_queries, a.seed)?;
    print_rank(&report)?;
    if let Some(p) = &a.json {
        write_json(p, &report)?;
    }
    Ok(())
}

/// `learner report`.
#[derive(Debug, Args)]
pub struct ReportArgs {
    /// model.json.
    #[arg(long)]
    pub model: PathBuf,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Features CSV (needed for the learning curve and the evaluation table).
    #[arg(long)]
    pub features: Option<PathBuf>,
    /// Training triplets (learning curve).
    #[arg(long)]
    pub triplets: Option<PathBuf>,
    /// Test triplets (learning curve and evaluation table).
    #[arg(long)]
    pub test: Option<PathBuf>,
    /// Training-set sizes of the learning curve.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "250,500,1000,2000,5000,10000,20000,50000"
    )]
    pub sizes: Vec<usize>,
    /// Seed for the learning-curve subsets.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

/// Runs `learner report`.
pub fn run_report(a: &ReportArgs) -> Result<()> {
    let model = Model::load(&a.model)?;
    let mut curve = None;
    let mut extra = String::new();
    if let (Some(f), Some(test)) = (&a.features, &a.test) {
        let table = read_features(f)?;
        let test = read_triplets(test, &table, false)?;
        let report = evaluate(&model, &table, &test.triplets, &BootstrapParams::default())?;
        extra.push_str("<h2>Test triplets</h2><table><tr><th>metric</th><th>labels</th><th>accuracy [95% CI]</th><th>perplexity [95% CI]</th><th>n</th></tr>");
        for (name, m) in [
            ("learned", &report.learned),
            ("uniform", &report.uniform),
            ("random", &report.random),
        ] {
            let mut rows = vec![("raw", &m.raw)];
            if let Some(s) = &m.majority {
                rows.push(("majority", s));
            }
            for (kind, s) in rows {
                extra.push_str(&format!(
                    "<tr><td>{name}</td><td>{kind}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                    est(&s.accuracy),
                    est(&s.perplexity),
                    s.n
                ));
            }
        }
        extra.push_str("</table>");
        if let Some(tr) = &a.triplets {
            let train_set = read_triplets(tr, &table, false)?;
            let pb = bar(a.sizes.len() as u64, "learning curve");
            let points = learning_curve(
                &model,
                &table,
                &train_set,
                &test.triplets,
                &a.sizes,
                a.seed,
                &mut |done, total| {
                    pb.set_length(total as u64);
                    pb.set_position(done as u64);
                },
            )?;
            pb.finish_and_clear();
            curve = Some(points);
        }
    } else if a.triplets.is_some() || a.test.is_some() {
        bail!("the learning curve needs --features, --triplets and --test");
    }
    let files = write_report(&a.out, &model, curve.as_deref(), &extra)?;
    for f in files {
        outln!("{}", f.display())?;
    }
    Ok(())
}

/// `learner bench metric`: fit and CV timings, argmin vs nlopt vs SciPy.
#[derive(Debug, Args)]
pub struct BenchMetricArgs {
    /// Features CSV (default: a simulated 169-feature crowd).
    #[arg(long)]
    pub features: Option<PathBuf>,
    /// Labels CSV to generate labelled triplets from (with --features).
    #[arg(long)]
    pub labels: Option<PathBuf>,
    /// Triplets.
    #[arg(long, default_value_t = 50_000)]
    pub n: usize,
    /// λ of the single fit (default: 10⁻³ per triplet).
    #[arg(long)]
    pub lambda: Option<f64>,
    /// Python script timing SciPy's L-BFGS-B on the exported problem.
    #[arg(long, default_value = "scripts/bench/scipy_lbfgsb.py")]
    pub scipy: PathBuf,
    /// Skip the SciPy run.
    #[arg(long)]
    pub no_scipy: bool,
    /// Skip the CV run.
    #[arg(long)]
    pub no_cv: bool,
    /// Skip the NLopt fit (when built with the `nlopt` feature).
    #[arg(long)]
    pub no_nlopt: bool,
    /// Write results as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

#[derive(Debug, serde::Serialize, serde::Deserialize)]
struct ScipyResult {
    seconds: f64,
    objective: f64,
    evaluations: u64,
    iterations: u64,
    message: String,
    numpy_eval_seconds: f64,
}

#[derive(Debug, serde::Serialize)]
struct BenchResult {
    triplets: usize,
    features: usize,
    threads: usize,
    lambda: f64,
    fits: Vec<SolverInfo>,
    scipy: Option<ScipyResult>,
    one_eval_seconds: f64,
    cv_seconds: Option<f64>,
    cv_passes: u64,
}

/// A fresh folder under the system temp dir for exported benchmark data.
fn scratch_dir() -> Result<PathBuf> {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let dir = std::env::temp_dir().join(format!("learner-bench-{}-{nanos}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

fn export_problem(
    dir: &Path,
    x: &[f64],
    dim: usize,
    set: &TripletSet,
    lambda: f64,
    w0: &[f64],
) -> Result<()> {
    let f64s = |v: &[f64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    std::fs::write(dir.join("x.f64"), f64s(x))?;
    std::fs::write(dir.join("w0.f64"), f64s(w0))?;
    let mut idx = Vec::with_capacity(set.triplets.len() * 16);
    for t in &set.triplets {
        for v in [t.a, t.b, t.c, t.q as u32] {
            idx.extend(v.to_le_bytes());
        }
    }
    std::fs::write(dir.join("triplets.u32"), idx)?;
    write_json(
        &dir.join("problem.json"),
        &serde_json::json!({
            "rows": x.len() / dim, "dim": dim, "triplets": set.triplets.len(),
            "lambda": lambda, "smoothing": DEFAULT_SMOOTHING,
            "objective": "sum_i softplus(-s_i (sqrt(w.dac^2+eps) - sqrt(w.dab^2+eps))) + lambda*sum(w), s_i = +1 if q else -1",
        }),
    )
}

/// Runs the metric benchmark and prints a table.
pub fn bench_metric(a: &BenchMetricArgs) -> Result<()> {
    let (table, set): (FeatureTable, TripletSet) = match (&a.features, &a.labels) {
        (Some(f), Some(l)) => {
            let table = read_features(f)?;
            let mut labels = read_labels(l)?;
            labels.retain(|x| table.index_of(&x.id).is_some());
            let recs = generate_labelled(&labels, a.n, a.seed)?;
            let dir = scratch_dir()?;
            let p = dir.join("t.csv");
            write_triplets(&recs, &p)?;
            let set = read_triplets(&p, &table, false)?;
            (table, set)
        }
        (None, None) => {
            let sim = simulate(&SimulationParams {
                items: 3000,
                dim: 169,
                support: 25,
                triplets: a.n,
                seed: a.seed,
                ..SimulationParams::default()
            })?;
            let set = TripletSet {
                triplets: sim.triplets.clone(),
                skipped: 0,
                skip_examples: vec![],
                has_workers: true,
            };
            (sim.table, set)
        }
        _ => bail!("--features and --labels go together"),
    };
    let threads = rayon::current_num_threads();
    let (mean, scale) = fit_scaling(&table, &[]);
    let std = standardise(&table, &mean, &scale);
    let dim = std.dim;
    let n = set.triplets.len();
    let lambda = a.lambda.unwrap_or(1e-3 * n as f64);
    let c = fit_uniform_scale(&std.x, dim, &set.triplets);
    let w0 = vec![c; dim];
    let obj = TripletObjective::new(&std.x, dim, &set.triplets, lambda, DEFAULT_SMOOTHING);
    // One evaluation, timed over a few repeats.
    let mut g = vec![0.0; dim];
    let t = Instant::now();
    let reps = 10;
    for _ in 0..reps {
        learner::metric::objective::FusedObjective::eval(&obj, &w0, &mut g);
    }
    let one_eval = t.elapsed().as_secs_f64() / reps as f64;
    // Solver settings comparable to SciPy's defaults (factr 1e7 ⇒ ftol ≈ 2.2e-9, pgtol 1e-5).
    let lb = LbfgsParams {
        ftol: 2.2e-9,
        pgtol: 1e-5,
        ..LbfgsParams::default()
    };
    let mut fits = Vec::new();
    let mut kinds = vec![SolverKind::Argmin];
    if cfg!(feature = "nlopt") && !a.no_nlopt {
        kinds.push(SolverKind::Nlopt);
    }
    for kind in kinds {
        let (_, info) = minimise(kind, obj, w0.clone(), &lb, &mut |_, _| {})?;
        fits.push(info);
    }
    let scipy = if a.no_scipy {
        None
    } else {
        let dir = scratch_dir()?;
        export_problem(&dir, &std.x, dim, &set, lambda, &w0)?;
        let out = Command::new("python3")
            .arg(&a.scipy)
            .arg(&dir)
            .output()
            .with_context(|| format!("cannot run python3 {}", a.scipy.display()))?;
        if !out.status.success() {
            bail!(
                "{} failed: {}",
                a.scipy.display(),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        Some(serde_json::from_slice::<ScipyResult>(&out.stdout).context("scipy script output")?)
    };
    let (cv_seconds, cv_passes) = if a.no_cv {
        (None, 0)
    } else {
        let grid = default_grid(n * 4 / 5, 8);
        let t = Instant::now();
        let pb = bar(40, "5-fold CV × 8 λ");
        let report = cross_validate(
            &std.x,
            dim,
            &set.triplets,
            &w0,
            &CvParams {
                folds: 5,
                grid,
                by_worker: set.has_workers,
                seed: a.seed,
                solver: SolverKind::Argmin,
                // The CV fits of `learner train`, with their stopping rule.
                lbfgs: TrainParams::default().cv_lbfgs,
                zero_threshold: 0.02,
                // The bench times the grid as given.
                max_extensions: 0,
                resamples: 0,
            },
            &mut |done, _| pb.set_position(done as u64),
        )?;
        pb.finish_and_clear();
        (Some(t.elapsed().as_secs_f64()), report.evaluations)
    };
    outln!(
        "metric bench: {n} triplets × {dim} features, λ = {lambda}, {threads} threads; one fused \
         evaluation {:.2} ms",
        one_eval * 1e3
    )?;
    outln!(
        "{:<28} {:>9} {:>6} {:>6} {:>10} {:>22} {:>12}",
        "solver",
        "seconds",
        "evals",
        "curv",
        "iters",
        "objective",
        "vs argmin"
    )?;
    let base = fits[0].seconds;
    for f in &fits {
        outln!(
            "{:<28} {:>9.3} {:>6} {:>6} {:>10} {:>22.9} {:>11.2}x",
            format!("{:?}", f.solver),
            f.seconds,
            f.evaluations,
            f.curvature_passes,
            f.iterations,
            f.objective,
            f.seconds / base
        )?;
    }
    if let Some(s) = &scipy {
        outln!(
            "{:<28} {:>9.3} {:>6} {:>6} {:>10} {:>22.9} {:>11.2}x   (numpy eval {:.2} ms)",
            "SciPy L-BFGS-B",
            s.seconds,
            s.evaluations,
            0,
            s.iterations,
            s.objective,
            s.seconds / base,
            s.numpy_eval_seconds * 1e3
        )?;
    }
    if let Some(cv) = cv_seconds {
        outln!(
            "argmin 5-fold CV over 8 λ as in `learner train` (40 fits, warm starts, ftol {:e}): {cv:.2} s, {cv_passes} passes over the data",
            TrainParams::default().cv_lbfgs.ftol
        )?;
    }
    if let Some(p) = &a.json {
        write_json(
            p,
            &BenchResult {
                triplets: n,
                features: dim,
                threads,
                lambda,
                fits,
                scipy,
                one_eval_seconds: one_eval,
                cv_seconds,
                cv_passes,
            },
        )?;
    }
    Ok(())
}
