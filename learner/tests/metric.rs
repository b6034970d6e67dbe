//! End-to-end checks of the metric learner (issue 3): the simulated crowd, solver agreement,
//! optimality, and the whole train → eval → rank path on files.

use learner::eval::triplets::BootstrapParams;
use learner::eval::{evaluate, predict};
use learner::metric::cv::held_out_scores;
use learner::metric::objective::{DEFAULT_SMOOTHING, FusedObjective, TripletObjective};
use learner::metric::simulate::{Simulation, SimulationParams, simulate};
use learner::metric::solver::{LbfgsParams, minimise_argmin, projected_gradient_norm};
use learner::metric::train::{LambdaChoice, TrainParams, train};
use learner::triplets::{Triplet, TripletSet};

fn set(triplets: &[Triplet]) -> TripletSet {
    TripletSet {
        triplets: triplets.to_vec(),
        skipped: 0,
        skip_examples: vec![],
        has_workers: true,
    }
}

fn accuracy(p_one: &[f64], triplets: &[Triplet]) -> f64 {
    let right = p_one
        .iter()
        .zip(triplets)
        .filter(|(p, t)| (**p > 0.5) == t.q)
        .count();
    right as f64 / triplets.len() as f64
}

/// Stopping rules tight enough that different solvers and paths meet at one optimum.
fn tight_params() -> LbfgsParams {
    LbfgsParams {
        ftol: 1e-13,
        pgtol: 1e-8,
        max_iters: 3000,
        ..LbfgsParams::default()
    }
}

/// The simulated crowd: 25,000 answers, 10% spammers, sparse `w*` on 6 of 40 features.
fn crowd() -> Simulation {
    simulate(&SimulationParams::default()).unwrap()
}

#[test]
fn simulated_crowd_support_is_recovered_and_accuracy_matches_generator() {
    let sim = crowd();
    let params = TrainParams {
        lambda: LambdaChoice::Fixed(50.0),
        ..TrainParams::default()
    };
    let model = train(&sim.table, &set(&sim.triplets), &params, &mut |_| {}).unwrap();
    assert!(model.solver.converged, "{:?}", model.solver);
    let support: Vec<bool> = model.weights.iter().map(|w| *w > 0.0).collect();
    let truth: Vec<bool> = sim.true_weights.iter().map(|w| *w > 0.0).collect();
    assert_eq!(support, truth, "learned {:?}", model.weights);

    let fresh = sim.fresh(20_000, 99);
    let learned = accuracy(
        &predict(&model, &sim.table, &fresh, &model.weights).unwrap(),
        &fresh,
    );
    let generating: Vec<f64> = fresh
        .iter()
        .map(|t| sim.true_probability(t.a, t.b, t.c))
        .collect();
    let generating = accuracy(&generating, &fresh);
    assert!(
        learned >= generating - 0.02,
        "learned {learned:.4} vs generating model {generating:.4}"
    );
}

#[test]
fn argmin_solution_satisfies_kkt() {
    let sim = simulate(&SimulationParams {
        triplets: 5000,
        ..SimulationParams::default()
    })
    .unwrap();
    let obj = TripletObjective::new(
        &sim.features,
        sim.dim,
        &sim.triplets,
        10.0,
        DEFAULT_SMOOTHING,
    );
    let params = LbfgsParams {
        ftol: 1e-14,
        pgtol: 1e-7,
        ..LbfgsParams::default()
    };
    let (w, info) = minimise_argmin(obj, vec![0.3; sim.dim], &params, &mut |_, _| {}).unwrap();
    assert!(w.iter().all(|v| *v >= 0.0));
    let mut g = vec![0.0; sim.dim];
    let f = obj.eval(&w, &mut g);
    assert!((f - info.objective).abs() <= 1e-12 * f);
    // KKT for w ≥ 0: g_k = 0 where w_k > 0, g_k ≥ 0 where w_k = 0 (relative to the data term).
    assert!(
        projected_gradient_norm(&w, &g) <= 1e-4,
        "{info:?} pg {}",
        projected_gradient_norm(&w, &g)
    );
    assert!(info.evaluations < 100, "{info:?}");
    // Perturbing any coordinate within the feasible set does not improve the objective.
    let mut scratch = vec![0.0; sim.dim];
    for k in 0..sim.dim {
        for h in [1e-4, -1e-4] {
            let mut wp = w.clone();
            wp[k] = (wp[k] + h).max(0.0);
            assert!(obj.eval(&wp, &mut scratch) >= f - 1e-9 * f, "k={k} h={h}");
        }
    }
}

#[cfg(feature = "nlopt")]
#[test]
fn argmin_and_nlopt_reach_the_same_optimum() {
    use learner::metric::solver::minimise_nlopt;
    use learner::metric::train::fit_uniform_scale;
    for (seed, lambda) in [(3u64, 10.0), (4, 40.0)] {
        let sim = simulate(&SimulationParams {
            triplets: 4000,
            seed,
            ..SimulationParams::default()
        })
        .unwrap();
        let obj = TripletObjective::new(
            &sim.features,
            sim.dim,
            &sim.triplets,
            lambda,
            DEFAULT_SMOOTHING,
        );
        let params = LbfgsParams {
            ftol: 1e-15,
            pgtol: 1e-8,
            max_iters: 2000,
            ..LbfgsParams::default()
        };
        let c = fit_uniform_scale(&sim.features, sim.dim, &sim.triplets);
        let w0 = vec![c; sim.dim];
        let (wa, ia) = minimise_argmin(obj, w0.clone(), &params, &mut |_, _| {}).unwrap();
        let (wn, inl) = minimise_nlopt(obj, w0, &params, &mut |_, _| {}).unwrap();
        let rel = (ia.objective - inl.objective).abs() / inl.objective;
        assert!(rel <= 1e-6, "objective {ia:?} vs {inl:?}");
        let dw = wa
            .iter()
            .zip(&wn)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(dw <= 1e-3, "weights differ by {dw}: {wa:?} vs {wn:?}");
    }
}

#[test]
fn cross_validation_picks_a_lambda_and_beats_uniform() {
    let sim = simulate(&SimulationParams {
        items: 150,
        dim: 12,
        support: 3,
        triplets: 1200,
        ..SimulationParams::default()
    })
    .unwrap();
    let params = TrainParams {
        lambda: LambdaChoice::Auto(None),
        folds: 3,
        grid_size: 2,
        ..TrainParams::default()
    };
    let mut fits = 0;
    let model = train(&sim.table, &set(&sim.triplets), &params, &mut |p| {
        if let learner::metric::train::TrainProgress::Cv { .. } = p {
            fits += 1
        }
    })
    .unwrap();
    let cv = model.cv.as_ref().unwrap();
    // The 2-point grid, plus a decade at an end for each extension of the λ search (the grid
    // must bracket the choice), each fitted in all 3 folds.
    let extended: usize = cv.extensions.iter().sum();
    assert_eq!(cv.rows.len(), 2 + extended);
    assert_eq!(fits, 3 * cv.rows.len());
    assert_eq!(cv.grouped_by, "worker");
    assert!(cv.rows.iter().any(|r| r.lambda == model.lambda));
    // Deterministic for a seed.
    let again = train(&sim.table, &set(&sim.triplets), &params, &mut |_| {}).unwrap();
    assert_eq!(model, Model2::strip(again, &model));

    let fresh = sim.fresh(3000, 5);
    let report = evaluate(
        &model,
        &sim.table,
        &fresh,
        &BootstrapParams {
            resamples: 200,
            seed: 1,
        },
    )
    .unwrap();
    assert!(report.learned.raw.accuracy.value > report.uniform.raw.accuracy.value + 0.05);
    assert!(report.learned.raw.perplexity.value < report.uniform.raw.perplexity.value);
    assert_eq!(report.random.raw.accuracy.value, 0.5);
    assert_eq!(report.random.raw.perplexity.value, 2.0);
    let maj = report.learned.majority.unwrap();
    // Majority labels remove rater noise: the model agrees with them more often.
    assert!(maj.accuracy.value > report.learned.raw.accuracy.value);
    let _ = held_out_scores;
}

/// Timing fields differ between runs; everything else must not.
struct Model2;
impl Model2 {
    fn strip(
        mut m: learner::metric::Model,
        like: &learner::metric::Model,
    ) -> learner::metric::Model {
        m.solver.seconds = like.solver.seconds;
        m
    }
}

#[test]
fn rank_metrics_match_scikit_learn() {
    let text = include_str!("data/metric/rank_reference.json");
    let v: serde_json::Value = serde_json::from_str(text).unwrap();
    for case in v["cases"].as_array().unwrap() {
        let dim = case["dim"].as_u64().unwrap() as usize;
        let y: Vec<f64> = case["points"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let labels: Vec<u32> = case["labels"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap() as u32)
            .collect();
        let queries: Vec<usize> = (0..labels.len()).collect();
        let got = learner::eval::rank::rank_queries(&y, dim, &labels, &queries);
        assert_eq!(got.queries as u64, case["queries"].as_u64().unwrap());
        let e = &case["expected"];
        for (name, value) in [
            ("auc", got.auc),
            ("map", got.map),
            ("mrr", got.mrr),
            ("prec_at_3", got.prec_at_3),
            ("prec_at_10", got.prec_at_10),
            ("ndcg_at_3", got.ndcg_at_3),
            ("ndcg_at_10", got.ndcg_at_10),
        ] {
            let want = e[name].as_f64().unwrap();
            assert!(
                (value - want).abs() < 1e-12,
                "seed {}: {name} {value} vs sklearn {want}",
                case["seed"]
            );
        }
    }
}

#[test]
fn files_train_eval_rank_report_round_trip() {
    use learner::table::{Label, read_features, write_features_to};
    use learner::triplets::read_triplets;
    let sim = simulate(&SimulationParams {
        items: 120,
        dim: 10,
        support: 3,
        triplets: 1500,
        ..SimulationParams::default()
    })
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let fpath = dir.path().join("features.csv");
    write_features_to(&sim.table, std::fs::File::create(&fpath).unwrap(), &fpath).unwrap();
    let tpath = dir.path().join("t.csv");
    let ids = sim.table.ids();
    let mut text = String::from("a,b,c,q,worker\n");
    for t in &sim.triplets {
        text.push_str(&format!(
            "{},{},{},{},w{}\n",
            ids[t.a as usize],
            ids[t.b as usize],
            ids[t.c as usize],
            t.q as u8,
            t.worker.unwrap()
        ));
    }
    std::fs::write(&tpath, text).unwrap();
    let table = read_features(&fpath).unwrap();
    let set = read_triplets(&tpath, &table, false).unwrap();
    let key = |t: &Triplet| (t.a, t.b, t.c, t.q);
    assert_eq!(
        set.triplets.iter().map(key).collect::<Vec<_>>(),
        sim.triplets.iter().map(key).collect::<Vec<_>>()
    );
    assert!(set.has_workers);
    let params = TrainParams {
        lambda: LambdaChoice::Fixed(5.0),
        ..TrainParams::default()
    };
    let model = train(&table, &set, &params, &mut |_| {}).unwrap();
    let mpath = dir.path().join("model.json");
    model.save(&mpath).unwrap();
    let loaded = learner::metric::Model::load(&mpath).unwrap();
    assert_eq!(loaded, model);
    assert_eq!(model.data.triplets, 1500);
    assert_eq!(model.data.sha256.len(), 64);

    // Items are ranked by their true nearest cluster: label by the sign of the heaviest feature.
    let heavy = (0..sim.dim)
        .max_by(|&a, &b| sim.true_weights[a].total_cmp(&sim.true_weights[b]))
        .unwrap();
    let labels: Vec<Label> = (0..table.len())
        .map(|i| Label {
            id: ids[i].clone(),
            style: if table.row(i)[heavy] > 0.0 { "p" } else { "n" }.into(),
            concept: String::new(),
        })
        .collect();
    let r = learner::eval::rank(&model, &table, &labels, None, 0).unwrap();
    assert_eq!((r.items, r.styles, r.missing), (120, 2, 0));
    assert!(r.learned.auc > r.uniform.auc, "{r:?}");

    let out = dir.path().join("report");
    let files = learner::eval::report::write_report(&out, &model, None, "").unwrap();
    assert!(
        files
            .iter()
            .all(|f| std::fs::metadata(f).unwrap().len() > 100)
    );
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("weights.svg") && html.contains("lambda") == model.cv.is_some());

    // A features file with other columns is refused with a clear message.
    let other =
        learner::table::FeatureTable::new(vec!["x".into()], vec!["item0".into()], vec![1.0])
            .unwrap();
    let e = model.standardise(&other).unwrap_err().to_string();
    assert!(e.contains("model has 10 features, file has 1"), "{e}");
}

/// The acceptance check: on the fixture icons (features snapshot and labelled-group
/// triplets in `tests/data/metric/`, made by `scripts/metric/fixture_features.py`), argmin and
/// NLopt reach the same objective (1e-6 relative) and weights (1e-3).
#[cfg(feature = "nlopt")]
#[test]
fn argmin_and_nlopt_agree_on_the_fixtures() {
    use learner::metric::model::{fit_scaling, standardise};
    use learner::metric::solver::minimise_nlopt;
    use learner::metric::train::fit_uniform_scale;
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/metric");
    let table = learner::table::read_features(&dir.join("fixture-features.csv")).unwrap();
    let set =
        learner::triplets::read_triplets(&dir.join("fixture-triplets.csv"), &table, false).unwrap();
    assert_eq!((table.len(), set.triplets.len()), (200, 1000));
    let (mean, scale) = fit_scaling(&table, &[]);
    let std = standardise(&table, &mean, &scale);
    let c = fit_uniform_scale(&std.x, std.dim, &set.triplets);
    let params = tight_params();
    let lambda = 10.0;
    let obj = TripletObjective::new(&std.x, std.dim, &set.triplets, lambda, DEFAULT_SMOOTHING);
    let w0 = vec![c; std.dim];
    let (wa, ia) = minimise_argmin(obj, w0.clone(), &params, &mut |_, _| {}).unwrap();
    let (wn, inl) = minimise_nlopt(obj, w0, &params, &mut |_, _| {}).unwrap();
    let rel = (ia.objective - inl.objective).abs() / inl.objective;
    assert!(rel <= 1e-6, "λ={lambda}: objective {ia:?} vs {inl:?}");
    let dw = wa
        .iter()
        .zip(&wn)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(dw <= 1e-3, "λ={lambda}: weights differ by {dw}");
}

/// Regression: with a single triplet the likelihood along the uniform ray is monotone, so the
/// start is huge and the objective nearly linear; the solver used to crawl for 1000 iterations.
#[test]
fn degenerate_single_triplet_fit_converges_quickly() {
    let table = learner::table::FeatureTable::new(
        vec!["f0".into(), "f1".into()],
        vec!["x".into(), "y".into(), "z".into()],
        vec![0.0, 0.0, 0.1, 1.0, 2.0, 0.5],
    )
    .unwrap();
    let t = Triplet {
        a: 0,
        b: 1,
        c: 2,
        q: true,
        worker: None,
        tuple: 0,
    };
    let params = TrainParams {
        lambda: LambdaChoice::Fixed(1.0),
        ..TrainParams::default()
    };
    let m = train(&table, &set(&[t]), &params, &mut |_| {}).unwrap();
    assert!(
        m.solver.converged && m.solver.iterations < 50,
        "{:?}",
        m.solver
    );
    assert!(m.solver.objective.is_finite() && m.weights.iter().all(|w| w.is_finite()));
}

/// The fixture problem of `argmin_and_nlopt_agree_on_the_fixtures`: standardised features, the
/// triplets, and the uniform start.
fn fixture_problem() -> (Vec<f64>, usize, Vec<Triplet>, Vec<f64>) {
    use learner::metric::model::{fit_scaling, standardise};
    use learner::metric::train::fit_uniform_scale;
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/metric");
    let table = learner::table::read_features(&dir.join("fixture-features.csv")).unwrap();
    let set =
        learner::triplets::read_triplets(&dir.join("fixture-triplets.csv"), &table, false).unwrap();
    let (mean, scale) = fit_scaling(&table, &[]);
    let std = standardise(&table, &mean, &scale);
    let c = fit_uniform_scale(&std.x, std.dim, &set.triplets);
    let w0 = vec![c; std.dim];
    (std.x, std.dim, set.triplets, w0)
}

#[test]
fn rescaling_reaches_the_same_optimum_in_fewer_evaluations_on_real_features() {
    let (x, dim, triplets, w0) = fixture_problem();
    let obj = TripletObjective::new(&x, dim, &triplets, 10.0, DEFAULT_SMOOTHING);
    let tight = tight_params();
    let plain = LbfgsParams {
        rescale_every: 0,
        ..tight
    };
    let (ws, is) = minimise_argmin(obj, w0.clone(), &tight, &mut |_, _| {}).unwrap();
    let (wp, ip) = minimise_argmin(obj, w0, &plain, &mut |_, _| {}).unwrap();
    assert!(is.converged && ip.converged, "{is:?} {ip:?}");
    assert_eq!(ip.curvature_passes, 0);
    assert!(is.curvature_passes >= 1);
    let rel = (is.objective - ip.objective).abs() / ip.objective;
    assert!(
        rel <= 1e-6,
        "objective {} vs {}",
        is.objective,
        ip.objective
    );
    let dw = ws
        .iter()
        .zip(&wp)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(dw <= 1e-3, "weights differ by {dw}");
    // Real features are badly scaled: the diagonal preconditioning must pay for its passes.
    assert!(
        is.evaluations + is.curvature_passes < ip.evaluations,
        "rescaled {} + {} passes vs plain {}",
        is.evaluations,
        is.curvature_passes,
        ip.evaluations
    );
}

#[test]
fn curvature_diagonal_matches_finite_differences_of_the_margins() {
    use learner::metric::objective::sigmoid;
    let sim = simulate(&SimulationParams {
        items: 80,
        dim: 10,
        support: 4,
        triplets: 300,
        ..SimulationParams::default()
    })
    .unwrap();
    let obj = TripletObjective::new(&sim.features, sim.dim, &sim.triplets, 1.0, 1e-8);
    let w: Vec<f64> = (0..sim.dim).map(|k| 0.2 + 0.1 * k as f64).collect();
    let h = obj.curvature_diagonal(&w).unwrap();
    let m0 = obj.margins(&w);
    for k in 0..sim.dim {
        // Central differences of every margin give ∂m_i/∂w_k independently of the objective code.
        let step = 1e-6;
        let (mut wp, mut wm) = (w.clone(), w.clone());
        wp[k] += step;
        wm[k] -= step;
        let (mp, mm) = (obj.margins(&wp), obj.margins(&wm));
        let expected: f64 = (0..m0.len())
            .map(|i| {
                let j = (mp[i] - mm[i]) / (2.0 * step);
                let s = sigmoid(m0[i]);
                s * (1.0 - s) * j * j
            })
            .sum();
        assert!(
            (h[k] - expected).abs() <= 1e-5 * expected.abs().max(1e-3),
            "k={k}: {} vs {expected}",
            h[k]
        );
    }
}

#[test]
fn curvature_memory_carried_along_the_lambda_path_keeps_the_optimum() {
    use learner::metric::solver::{CurvatureMemory, SolverKind, minimise_warm};
    let (x, dim, triplets, w0) = fixture_problem();
    let params = tight_params();
    let first = TripletObjective::new(&x, dim, &triplets, 3.0, DEFAULT_SMOOTHING);
    let second = TripletObjective::new(&x, dim, &triplets, 10.0, DEFAULT_SMOOTHING);
    let mut memory = CurvatureMemory::default();
    let (w1, _) = minimise_warm(
        SolverKind::Argmin,
        first,
        w0,
        &params,
        &mut memory,
        &mut |_, _| {},
    )
    .unwrap();
    let (warm_w, warm) = minimise_warm(
        SolverKind::Argmin,
        second,
        w1.clone(),
        &params,
        &mut memory,
        &mut |_, _| {},
    )
    .unwrap();
    let (cold_w, cold) = minimise_argmin(second, w1, &params, &mut |_, _| {}).unwrap();
    assert!(warm.converged && cold.converged, "{warm:?} {cold:?}");
    let rel = (warm.objective - cold.objective).abs() / cold.objective;
    assert!(
        rel <= 1e-6,
        "objective {} vs {}",
        warm.objective,
        cold.objective
    );
    let dw = warm_w
        .iter()
        .zip(&cold_w)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(dw <= 1e-3, "weights differ by {dw}");
    let kkt = {
        let mut g = vec![0.0; dim];
        second.eval(&warm_w, &mut g);
        projected_gradient_norm(&warm_w, &g)
    };
    assert!(kkt <= 1e-4, "projected gradient {kkt}");
}

#[test]
fn curvature_memory_from_another_dimension_is_dropped() {
    use learner::metric::solver::{CurvatureMemory, SolverKind, minimise_warm};
    let (x, dim, triplets, w0) = fixture_problem();
    let params = LbfgsParams::default();
    let big = TripletObjective::new(&x, dim, &triplets, 10.0, DEFAULT_SMOOTHING);
    let mut memory = CurvatureMemory::default();
    let (_, first) = minimise_warm(
        SolverKind::Argmin,
        big,
        w0,
        &params,
        &mut memory,
        &mut |_, _| {},
    )
    .unwrap();
    assert!(first.converged, "{first:?}");
    // The same memory on a 10-feature simulated problem: a fresh start, not a misaligned one.
    let sim = simulate(&SimulationParams {
        items: 80,
        dim: 10,
        support: 4,
        triplets: 400,
        ..SimulationParams::default()
    })
    .unwrap();
    let small = TripletObjective::new(&sim.features, sim.dim, &sim.triplets, 1.0, 1e-8);
    let (w, warm) = minimise_warm(
        SolverKind::Argmin,
        small,
        vec![0.5; sim.dim],
        &params,
        &mut memory,
        &mut |_, _| {},
    )
    .unwrap();
    let (_, cold) = minimise_argmin(small, vec![0.5; sim.dim], &params, &mut |_, _| {}).unwrap();
    assert_eq!(w.len(), sim.dim);
    assert_eq!(warm.evaluations, cold.evaluations);
    assert_eq!(warm.objective, cold.objective);
}
