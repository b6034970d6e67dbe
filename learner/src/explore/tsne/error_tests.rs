//! Every error of t-SNE and its quality measures, as an error value (never a panic).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::quality::{self, knn_preservation, trustworthiness};
use super::*;

fn random(n: usize, dim: usize, seed: u64) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n * dim).map(|_| rng.random_range(-1.0..1.0)).collect()
}

#[test]
fn every_error_is_reported() {
    let ok = random(100, 2, 9);
    let params = TsneParams {
        perplexity: 5.0,
        ..TsneParams::default()
    };
    let run = |x: &[f32], dim: usize, p: &TsneParams| tsne(x, dim, p, &mut |_, _| {}).unwrap_err();
    assert!(matches!(
        run(&ok, 0, &params),
        Error::InvalidParameter { name: "dim", .. }
    ));
    assert!(matches!(
        run(&ok[..199], 2, &params),
        Error::NotAMatrix { len: 199, dim: 2 }
    ));
    assert!(matches!(
        run(&ok[..30], 2, &params),
        Error::TsneTooFewPoints {
            n: 15,
            needed: 16,
            ..
        }
    ));
    let too_many = vec![0.0f32; MAX_POINTS + 1];
    assert!(matches!(
        run(&too_many, 1, &params),
        Error::TsneTooManyPoints { .. }
    ));
    for bad in [f32::NAN, f32::INFINITY, 1e16] {
        let mut x = ok.clone();
        x[41] = bad;
        assert!(matches!(
            run(&x, 2, &params),
            Error::BadCoordinate {
                row: 20,
                column: 1,
                ..
            }
        ));
    }
    let bad_params: [(&str, TsneParams); 9] = [
        (
            "perplexity",
            TsneParams {
                perplexity: 1.5,
                ..params.clone()
            },
        ),
        (
            "n_iter",
            TsneParams {
                n_iter: 0,
                ..params.clone()
            },
        ),
        (
            "early_exaggeration",
            TsneParams {
                early_exaggeration: 0.5,
                ..params.clone()
            },
        ),
        (
            "early_exaggeration_iter",
            TsneParams {
                early_exaggeration_iter: 800,
                ..params.clone()
            },
        ),
        (
            "learning_rate",
            TsneParams {
                learning_rate: Some(-1.0),
                ..params.clone()
            },
        ),
        (
            "initial_momentum",
            TsneParams {
                initial_momentum: 1.0,
                ..params.clone()
            },
        ),
        (
            "final_momentum",
            TsneParams {
                final_momentum: f64::NAN,
                ..params.clone()
            },
        ),
        (
            "min_gain",
            TsneParams {
                min_gain: 0.0,
                ..params.clone()
            },
        ),
        (
            "theta",
            TsneParams {
                theta: 1.5,
                ..params.clone()
            },
        ),
    ];
    for (name, p) in &bad_params {
        match run(&ok, 2, p) {
            Error::InvalidParameter { name: got, .. } => assert_eq!(got, *name),
            e => panic!("{name}: {e}"),
        }
        assert!(affinities(&ok, 2, p).is_err());
    }
    // A learning rate far too large overflows: an error, not NaN coordinates.
    let wild = TsneParams {
        learning_rate: Some(1e9),
        early_exaggeration: 1000.0,
        n_iter: 50,
        early_exaggeration_iter: 50,
        ..params.clone()
    };
    if let Err(e) = tsne(&ok, 2, &wild, &mut |_, _| {}) {
        assert!(matches!(e, Error::TsneDiverged { .. }), "{e}");
    }
    // The quality measures.
    let y = vec![[0.0f32; 2]; 100];
    assert!(matches!(
        trustworthiness(&ok, 2, &y[..99], 5),
        Err(Error::TsneShapeMismatch {
            expected: 100,
            got: 99,
            ..
        })
    ));
    assert!(matches!(
        trustworthiness(&ok, 2, &y, 50),
        Err(Error::InvalidParameter { name: "k", .. })
    ));
    assert!(matches!(
        knn_preservation(&ok, 2, &y, 0),
        Err(Error::InvalidParameter { name: "k", .. })
    ));
    assert!(matches!(
        knn_preservation(&ok[..199], 2, &y, 3),
        Err(Error::NotAMatrix { .. })
    ));
    let mut bad_y = y.clone();
    bad_y[3][1] = f32::NAN;
    assert!(matches!(
        knn_preservation(&ok, 2, &bad_y, 3),
        Err(Error::BadCoordinate {
            row: 3,
            column: 1,
            ..
        })
    ));
    let p = affinities(&ok, 2, &params).unwrap();
    assert!(matches!(
        quality::kl_divergence(&p, &y[..10]),
        Err(Error::TsneShapeMismatch {
            expected: 100,
            got: 10,
            ..
        })
    ));
}
