//! The fused, chunked TV-L1 sweep (module `tvl1`) against a plain transcription of the
//! iteration: the fast path must compute the same thing as the naive one.

use super::TvL1FlowParams;
use super::plane::Plane;

use super::tests::texture;

/// The fused, chunked sweep against a plain transcription of the IPOL iteration (separate
/// arrays, two full passes, no chunks) on a plane of three chunks, for a fixed number of
/// iterations (ε tiny, so both stop at `max_iterations`).
#[test]
fn one_level_matches_a_plain_transcription() {
    let t = texture(4);
    let (w, h) = (70usize, 260usize);
    let sample = |dx: f64, dy: f64| Plane {
        w,
        h,
        data: (0..w * h)
            .map(|i| 255.0 * t((i % w) as f64 - dx, (i / w) as f64 - dy) as f32)
            .collect(),
    };
    let (i0, i1) = (sample(0.0, 0.0), sample(0.8, -0.5));
    let params = TvL1FlowParams {
        warps: 2,
        max_iterations: 25,
        epsilon: 1e-12,
        ..Default::default()
    };
    let mut fast = vec![[0.1f32, -0.2]; w * h];
    let (its, _) = super::tvl1::solve_level(&i0, &i1, &mut fast, &params);
    assert_eq!(its, 50);

    // The transcription.
    let n = w * h;
    let (lt, theta, taut) = (
        params.lambda * params.theta,
        params.theta,
        params.tau / params.theta,
    );
    let (gx, gy) = i1.centred_gradient();
    let (mut u1, mut u2) = (vec![0.1f32; n], vec![-0.2f32; n]);
    let mut p = [
        vec![0.0f32; n],
        vec![0.0f32; n],
        vec![0.0f32; n],
        vec![0.0f32; n],
    ];
    for _ in 0..params.warps {
        let mut wx = vec![0.0f32; n];
        let mut wy = vec![0.0f32; n];
        let mut rho_c = vec![0.0f32; n];
        for i in 0..n {
            let (x, y) = ((i % w) as f32 + u1[i], (i / w) as f32 + u2[i]);
            wx[i] = gx.bicubic(x, y);
            wy[i] = gy.bicubic(x, y);
            rho_c[i] = i1.bicubic(x, y) - wx[i] * u1[i] - wy[i] * u2[i] - i0.data[i];
        }
        for _ in 0..params.max_iterations {
            let div = |q: &[f32], r: &[f32], i: usize| {
                let (x, y) = (i % w, i / w);
                let mut d = 0.0;
                if x + 1 < w {
                    d += q[i];
                }
                if x > 0 {
                    d -= q[i - 1];
                }
                if y + 1 < h {
                    d += r[i];
                }
                if y > 0 {
                    d -= r[i - w];
                }
                d
            };
            for i in 0..n {
                let g2 = wx[i] * wx[i] + wy[i] * wy[i];
                let rho = rho_c[i] + wx[i] * u1[i] + wy[i] * u2[i];
                let (d1, d2) = if rho < -lt * g2 {
                    (lt * wx[i], lt * wy[i])
                } else if rho > lt * g2 {
                    (-lt * wx[i], -lt * wy[i])
                } else if g2 < 1e-10 {
                    (0.0, 0.0)
                } else {
                    (-rho * wx[i] / g2, -rho * wy[i] / g2)
                };
                u1[i] = u1[i] + d1 + theta * div(&p[0], &p[1], i);
                u2[i] = u2[i] + d2 + theta * div(&p[2], &p[3], i);
            }
            for i in 0..n {
                let (x, y) = (i % w, i / w);
                let fwd = |u: &[f32]| {
                    let dx = if x + 1 < w { u[i + 1] - u[i] } else { 0.0 };
                    let dy = if y + 1 < h { u[i + w] - u[i] } else { 0.0 };
                    (dx, dy)
                };
                for (k, u) in [&u1, &u2].into_iter().enumerate() {
                    let (dx, dy) = fwd(u);
                    let r = 1.0 / (1.0 + taut * (dx * dx + dy * dy).sqrt());
                    p[2 * k][i] = (p[2 * k][i] + taut * dx) * r;
                    p[2 * k + 1][i] = (p[2 * k + 1][i] + taut * dy) * r;
                }
            }
        }
    }
    let worst = (0..n)
        .map(|i| (fast[i][0] - u1[i]).abs().max((fast[i][1] - u2[i]).abs()))
        .fold(0.0f32, f32::max);
    // Measured: identical (0 px); a chunk boundary reading the wrong duals gives 0.16 px.
    assert!(worst < 1e-4, "largest difference {worst} px");
}
