//! Leave-one-scene-out cross-validation of the light-field method's switches and weights on the
//! rendered tuning scenes (issue 21). For each scene, the setting with the lowest mean LMSE on
//! the *other* scenes is chosen from a grid and scored on the held-out one; the same is done
//! with a criterion on both scores (LMSE + incoherence, the issue asks for both). Prints every
//! setting's means, the per-fold choices and the cross-validated figures.
//!
//! `cargo run --release -p decompose --example lightfield_cv -- .cache/rendered-lightfields/tune`
//! (`--json FILE` also writes every score; `--only TEXT` runs the settings whose name contains
//! TEXT, e.g. `--only "prior zhao"`; `--mu` runs the grid of the data term's `μ` instead,
//! `--crease` that of the crease cue's step, `--crease-bound` that of the crease pairs' weight
//! and shading bound, `--crease-fine` a finer one around γ 2, `--crease-current` the pairs'
//! weight and bound at the current defaults, `--theta` that of the albedo cue's `θ_a`, `--beta`
//! that of the reflectance filter's `β`, `--data-term` that of the data term's `γ`, `μ` and
//! `κ_c`, `--toward-previous` the default with each choice that separates it from the defaults
//! before the ninth session set back on its own, `--centre` the tie's `κ_c` from 0.1 up,
//! `--unlit-centre` the unlit rays' fill shared from the centre view off and on). The grids
//! start from the default of the day they are run: since the twelfth session it shares the
//! centre view's fill with unlit rays, so figures documented before differ on scenes with a
//! large unlit shadow (scene81).
//!
//! The grid spans the choices that decide coherence and accuracy: the centre-view Retinex prior
//! (`LightFieldParams::retinex_prior`), the sheared filter (`LightFieldParams::shear`), the
//! occlusion and white/black cues and the filter's `β`.
//! Every other parameter keeps its default.

use std::path::{Path, PathBuf};

use decompose::lightfield::eval::{LightFieldScores, evaluate};
use decompose::lightfield::io::load_truth;
use decompose::lightfield::method::{
    DATA_MU, DataTermParams, LevelPrior, PREVIOUS_REFLECTANCE_BETA,
};
use decompose::lightfield::propagate::disparity_to_every_view;
use decompose::lightfield::{LightFieldParams, decompose as decompose_lf};

fn grid() -> Vec<(String, LightFieldParams)> {
    let mut out = Vec::new();
    let priors = [
        ("thesis", LevelPrior::Intensity),
        ("zhao", LevelPrior::CentreRetinex),
    ];
    for (prior_name, level_prior) in priors {
        for shear in [false] {
            for occlusion_cue in [true, false] {
                for white_black_cue in [true, false] {
                    for beta in [0.3f32, 1.0] {
                        let mut p = LightFieldParams {
                            level_prior,
                            shear,
                            occlusion_cue,
                            white_black_cue,
                            ..Default::default()
                        };
                        p.reflectance_filter.beta = beta;
                        let name = format!(
                            "prior {prior_name} shear {} occ {} wb {} beta {beta}",
                            shear as u8, occlusion_cue as u8, white_black_cue as u8
                        );
                        out.push((name, p));
                    }
                }
            }
        }
    }
    out
}

/// `--mu`: the data term's weight `μ` with either level prior, every other choice at its default.
fn mu_grid() -> Vec<(String, LightFieldParams)> {
    let mut out = Vec::new();
    for (prior_name, level_prior) in [
        ("thesis", LevelPrior::Intensity),
        ("zhao", LevelPrior::CentreRetinex),
    ] {
        for mu in [1e-3, 3e-3, 1e-2, 3e-2] {
            let mut p = LightFieldParams {
                level_prior,
                ..Default::default()
            };
            p.solve.mu = mu;
            out.push((format!("prior {prior_name} mu {mu:.0e}"), p));
        }
    }
    out
}

/// `--crease`: the crease cue's slope step (`CueParams::crease_step`), every other choice at
/// its default.
fn crease_grid() -> Vec<(String, LightFieldParams)> {
    [None, Some(1e-3), Some(1e-2), Some(3e-2)]
        .into_iter()
        .map(|crease_step| {
            let mut p = LightFieldParams::default();
            p.cues.crease_step = crease_step;
            (format!("crease {crease_step:?}"), p)
        })
        .collect()
}

/// `--crease-bound`: the crease pairs' weight `ω_crease` and the bound `T_c` on the shading
/// step they ask for (`CueParams::crease_weight`, `CueParams::crease_shading_step`), every other
/// choice at the defaults before the ninth session (`LightFieldParams::previous_defaults`, γ 1,
/// μ 1e-2). `ω_crease` 0.01 without a bound is those defaults.
fn crease_bound_grid() -> Vec<(String, LightFieldParams)> {
    let mut out = Vec::new();
    for weight in [0.01f32, 0.03, 0.1, 0.3] {
        for bound in [None, Some(0.4f32), Some(0.7), Some(1.1)] {
            let mut p = LightFieldParams::previous_defaults();
            p.cues.crease_weight = weight;
            p.cues.crease_shading_step = bound;
            out.push((format!("crease weight {weight} bound {bound:?}"), p));
        }
    }
    out
}

/// The defaults of the ninth session (reflectance filter β 1), with the data term at γ 2 and
/// `μ`, and the crease pairs at (`ω_crease`, `T_c`): the base of `--crease-dark`,
/// `--crease-fine` and `--theta`, which were run before β became 2.
fn ninth_session(mu: f64, weight: f32, bound: Option<f32>) -> (String, LightFieldParams) {
    let mut p = LightFieldParams::default();
    p.reflectance_filter.beta = PREVIOUS_REFLECTANCE_BETA;
    p.data_term.gamma = 2.0;
    p.solve.mu = mu;
    p.cues.crease_weight = weight;
    p.cues.crease_shading_step = bound;
    (
        format!("gamma 2 mu {mu:.0e} crease weight {weight} bound {bound:?}"),
        p,
    )
}

/// `--crease-dark`: the crease bound with the per-ray data term at γ 2 (the default since the
/// ninth session, first the dark-surface option) at two `μ`.
fn crease_dark_grid() -> Vec<(String, LightFieldParams)> {
    let pairs = [(0.01f32, None), (0.03, Some(0.7f32)), (0.1, Some(0.7))];
    [1e-2, 3e-2]
        .into_iter()
        .flat_map(|mu| pairs.map(|(weight, bound)| ninth_session(mu, weight, bound)))
        .collect()
}

/// `--crease-fine`: around the defaults of `--crease-dark` (γ 2): `μ` ∈ {1e-2, 2e-2, 3e-2} ×
/// crease pairs (`ω_crease`, `T_c`) between "weak and unbounded" and "strong and bounded".
fn crease_fine_grid() -> Vec<(String, LightFieldParams)> {
    let pairs = [
        (0.01f32, None),
        (0.01, Some(0.7f32)),
        (0.01, Some(1.1)),
        (0.03, None),
        (0.03, Some(0.7)),
        (0.03, Some(1.1)),
        (0.1, Some(0.7)),
        (0.1, Some(1.1)),
    ];
    [1e-2, 2e-2, 3e-2]
        .into_iter()
        .flat_map(|mu| pairs.map(|(weight, bound)| ninth_session(mu, weight, bound)))
        .collect()
}

/// `--crease-current`: the crease pairs' weight `ω_crease` and bound `T_c` at the current
/// defaults (β 2, γ 2, `μ` 3e-2): the grid that chose the eleventh session's (0.01, 1.1).
fn crease_current_grid() -> Vec<(String, LightFieldParams)> {
    let mut out = Vec::new();
    for weight in [0.01f32, 0.03, 0.1] {
        for bound in [None, Some(0.7f32), Some(1.1)] {
            let mut p = LightFieldParams::default();
            p.cues.crease_weight = weight;
            p.cues.crease_shading_step = bound;
            out.push((format!("crease weight {weight} bound {bound:?}"), p));
        }
    }
    out
}

/// `--theta`: the albedo cue's colour-line angle `θ_a` (eq. 4.10) around its default 0.005,
/// every other choice at the ninth session's defaults: whether texture that leaks into the
/// shading (dots on a panel, lines of text) is a matter of the threshold.
fn theta_grid() -> Vec<(String, LightFieldParams)> {
    [0.0025f32, 0.005, 0.01, 0.02]
        .into_iter()
        .map(|theta_a| {
            let (_, mut p) = ninth_session(DATA_MU, 0.1, Some(0.7));
            p.cues.theta_a = theta_a;
            (format!("theta_a {theta_a}"), p)
        })
        .collect()
}

/// `--beta`: the reflectance filter's `β` (eq. 4.3) around 1 and 2 (the default since the tenth
/// session), every other choice at the tenth session's defaults: a smaller `β` makes larger
/// structures coherent, a larger one leaves finer texture (lines of text, dots) in the
/// reflectance.
fn beta_grid() -> Vec<(String, LightFieldParams)> {
    [0.5f32, 1.0, 2.0, 4.0]
        .into_iter()
        .map(|beta| {
            // The crease pairs of the tenth session, when this grid was run, so that its
            // documented figures reproduce.
            let (_, mut p) = ninth_session(DATA_MU, 0.1, Some(0.7));
            p.reflectance_filter.beta = beta;
            (format!("beta {beta}"), p)
        })
        .collect()
}

/// `--toward-previous`: the default, the defaults before the ninth session, and the default with
/// each of the choices that separate them set back on its own (the reflectance filter's `β`, the
/// data term's `γ`, its `μ`, the crease pairs' weight, their bound; one the default shares with
/// the earlier defaults is left out): which of them costs the accuracy that the earlier
/// defaults have on ordinary scenes.
fn toward_previous_grid() -> Vec<(String, LightFieldParams)> {
    /// Sets one choice of the first parameters back to the second's.
    type SetBack = fn(&mut LightFieldParams, &LightFieldParams);
    let previous = LightFieldParams::previous_defaults();
    let one_back: [(&str, SetBack); 5] = [
        ("beta", |p, q| {
            p.reflectance_filter.beta = q.reflectance_filter.beta
        }),
        ("gamma", |p, q| p.data_term.gamma = q.data_term.gamma),
        ("mu", |p, q| p.solve.mu = q.solve.mu),
        ("crease weight", |p, q| {
            p.cues.crease_weight = q.cues.crease_weight
        }),
        ("crease bound", |p, q| {
            p.cues.crease_shading_step = q.cues.crease_shading_step
        }),
    ];
    let mut out = vec![
        ("default".to_owned(), LightFieldParams::default()),
        ("previous defaults".to_owned(), previous.clone()),
    ];
    for (name, set_back) in one_back {
        let mut p = LightFieldParams::default();
        set_back(&mut p, &previous);
        // A choice the default already shares with the previous defaults adds nothing.
        if p != LightFieldParams::default() {
            out.push((format!("default, previous {name}"), p));
        }
    }
    out
}

/// `--centre`: the weight `κ_c` of the dark rays' tie to the centre view's solution
/// (`method::data_term`) at and above its default 0.1, the top of the grid it was chosen from:
/// dark rays whose level each view's borders set are what the tie makes coherent.
fn centre_grid() -> Vec<(String, LightFieldParams)> {
    [0.1f32, 0.3, 1.0]
        .into_iter()
        .map(|centre_weight| {
            let mut p = LightFieldParams::default();
            p.data_term.centre_weight = centre_weight;
            (format!("centre {centre_weight}"), p)
        })
        .collect()
}

/// `--unlit-centre`: the unlit rays' fill shared from the centre view
/// (`LightFieldParams::unlit_from_centre`) off and on, from the default.
fn unlit_centre_grid() -> Vec<(String, LightFieldParams)> {
    [false, true]
        .into_iter()
        .map(|on| {
            let p = LightFieldParams {
                unlit_from_centre: on,
                ..Default::default()
            };
            (format!("unlit from centre {on}"), p)
        })
        .collect()
}

/// `--data-term`: the data term's `γ`, `μ` and `κ_c` (`method::data_term`), every other
/// choice at its default. `γ` = 0 is the thesis' data term (then `κ_c` has no effect).
fn data_term_grid() -> Vec<(String, LightFieldParams)> {
    let mut out = Vec::new();
    for gamma in [0.0f32, 1.0, 2.0, 3.0] {
        for mu in [1e-2, 3e-2, 1e-1] {
            for centre_weight in [0.0f32, 0.03, 0.1] {
                let mut p = LightFieldParams {
                    data_term: DataTermParams {
                        gamma,
                        centre_weight,
                    },
                    ..Default::default()
                };
                p.solve.mu = mu;
                out.push((
                    format!("gamma {gamma} mu {mu:.0e} centre {centre_weight}"),
                    p,
                ));
            }
        }
    }
    out
}

fn scenes(root: &Path) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(root)
        .expect("reading the tuning folder")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("truth").is_dir())
        .collect();
    found.sort();
    found
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let root = PathBuf::from(
        args.first()
            .ok_or("usage: lightfield_cv TUNE_DIR [--json FILE]")?,
    );
    let json = args
        .iter()
        .position(|a| a == "--json")
        .and_then(|i| args.get(i + 1))
        .map(PathBuf::from);
    // `--only TEXT`: run the settings whose name contains TEXT.
    let only = args
        .iter()
        .position(|a| a == "--only")
        .and_then(|i| args.get(i + 1))
        .cloned()
        .unwrap_or_default();
    let grid = if args.iter().any(|a| a == "--toward-previous") {
        toward_previous_grid()
    } else if args.iter().any(|a| a == "--mu") {
        mu_grid()
    } else if args.iter().any(|a| a == "--data-term") {
        data_term_grid()
    } else if args.iter().any(|a| a == "--beta") {
        beta_grid()
    } else if args.iter().any(|a| a == "--theta") {
        theta_grid()
    } else if args.iter().any(|a| a == "--unlit-centre") {
        unlit_centre_grid()
    } else if args.iter().any(|a| a == "--centre") {
        centre_grid()
    } else if args.iter().any(|a| a == "--crease-current") {
        crease_current_grid()
    } else if args.iter().any(|a| a == "--crease-fine") {
        crease_fine_grid()
    } else if args.iter().any(|a| a == "--crease-dark") {
        crease_dark_grid()
    } else if args.iter().any(|a| a == "--crease-bound") {
        crease_bound_grid()
    } else if args.iter().any(|a| a == "--crease") {
        crease_grid()
    } else {
        grid()
    };
    let settings: Vec<_> = grid
        .into_iter()
        .filter(|(n, _)| n.contains(&only))
        .collect();
    let names: Vec<String> = scenes(&root)
        .iter()
        .map(|s| {
            s.file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    // scores[setting][scene]
    let mut scores: Vec<Vec<LightFieldScores>> = vec![Vec::new(); settings.len()];
    for scene in scenes(&root) {
        let (folder, truth) = load_truth(&scene)?;
        let lf = &folder.field;
        let disparity = folder
            .disparity
            .as_ref()
            .map(|d| disparity_to_every_view(d, lf.rows(), lf.cols()))
            .transpose()?;
        for (k, (name, p)) in settings.iter().enumerate() {
            let (d, _) = decompose_lf(lf, disparity.as_ref(), p, &mut |_| {})?;
            let s = evaluate(&d, &truth)?;
            eprintln!(
                "{} {name:44} LMSE {:.4} incoherence {:.5}",
                scene.display(),
                s.lmse,
                s.incoherence
            );
            scores[k].push(s);
        }
    }
    let mean = |k: usize, skip: Option<usize>, f: &dyn Fn(&LightFieldScores) -> f64| {
        let v: Vec<f64> = scores[k]
            .iter()
            .enumerate()
            .filter(|(i, _)| Some(*i) != skip)
            .map(|(_, s)| f(s))
            .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let lmse = |s: &LightFieldScores| s.lmse;
    let incoh = |s: &LightFieldScores| s.incoherence;
    let both = |s: &LightFieldScores| s.lmse + s.incoherence;
    println!(
        "{:46} {:>8} {:>12}",
        "setting (in-sample means)", "LMSE", "incoherence"
    );
    for (k, (name, _)) in settings.iter().enumerate() {
        println!(
            "{name:46} {:8.4} {:12.5}",
            mean(k, None, &lmse),
            mean(k, None, &incoh)
        );
    }
    for (label, crit) in [
        ("LMSE", &lmse as &dyn Fn(&LightFieldScores) -> f64),
        ("LMSE + incoherence", &both),
    ] {
        println!("\nchosen by {label} on the other scenes:");
        let (mut l, mut c) = (0.0, 0.0);
        for (i, scene) in names.iter().enumerate() {
            let best = (0..settings.len())
                .min_by(|&a, &b| mean(a, Some(i), crit).total_cmp(&mean(b, Some(i), crit)))
                .unwrap_or(0);
            let s = &scores[best][i];
            println!(
                "  {scene}: {:44} LMSE {:.4} incoherence {:.5}",
                settings[best].0, s.lmse, s.incoherence
            );
            l += s.lmse;
            c += s.incoherence;
        }
        let n = names.len().max(1) as f64;
        println!(
            "  cross-validated mean: LMSE {:.4} incoherence {:.5}",
            l / n,
            c / n
        );
    }
    if let Some(path) = json {
        let rows: std::collections::BTreeMap<_, _> = settings
            .iter()
            .zip(&scores)
            .map(|((name, _), s)| {
                (
                    name.clone(),
                    names
                        .iter()
                        .cloned()
                        .zip(s.iter().cloned())
                        .collect::<std::collections::BTreeMap<_, _>>(),
                )
            })
            .collect::<std::collections::BTreeMap<_, _>>();
        std::fs::write(path, serde_json::to_string_pretty(&rows)?)?;
    }
    Ok(())
}
