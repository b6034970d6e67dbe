//! Speed of the MAP propagation (issue 20, steps 4–5) on one 800×600 frame with 50 clusters.
//!
//! ```text
//! nice -n 5 cargo run --release -p decompose --example propagate_speed
//! ```
//!
//! The scene: a seeded Voronoi partition into 50 cells, each a flat reflectance drawn at
//! random (one in five cells shares its colour with another one, so that the distance prior
//! has work to do) with a ±4% texture per pixel and channel, under a smooth shading (a sum of
//! cosines), all attached to the scene. Frame t+1
//! is the scene shifted by (3, −2) px (integer, so every colour of a visible pixel recurs in
//! the tables) and the flow is the true one. Prints the median wall time of 5 runs of
//! [`ClusterTables::from_frame`] and of [`propagate`], the CPU time, the distinct colours of
//! frame t+1, the assigned fraction, the share of assigned pixels with the true cluster, and
//! the time of [`should_stop`].

use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use decompose::video::flow::Flow;
use decompose::video::propagate::{ClusterTables, PropagateParams, propagate, should_stop};
use decompose::{Image, Labels};

const W: u32 = 800;
const H: u32 = 600;
const CLUSTERS: usize = 50;
const SHIFT: (i32, i32) = (3, -2);
/// Relative amplitude of the per-pixel reflectance texture.
const TEXTURE: f32 = 0.08;

struct Scene {
    seeds: Vec<(f32, f32)>,
    albedo: Vec<[f32; 3]>,
    waves: Vec<(f32, f32, f32, f32)>,
}

impl Scene {
    fn new() -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(2014);
        let seeds = (0..CLUSTERS)
            .map(|_| {
                (
                    rng.random_range(-20.0..W as f32 + 20.0),
                    rng.random_range(-20.0..H as f32 + 20.0),
                )
            })
            .collect();
        let mut albedo: Vec<[f32; 3]> = Vec::new();
        for k in 0..CLUSTERS {
            if k % 5 == 4 {
                let twin = albedo[rng.random_range(0..k)];
                albedo.push(twin);
            } else {
                albedo.push([0; 3].map(|_| rng.random_range(0.05f32..0.95)));
            }
        }
        let waves = (0..6)
            .map(|_| {
                let a = rng.random_range(0.0..std::f32::consts::TAU);
                let wl = rng.random_range(80.0f32..400.0);
                let ph = rng.random_range(0.0..std::f32::consts::TAU);
                (a.cos() / wl, a.sin() / wl, ph, rng.random_range(0.03..0.08))
            })
            .collect();
        Self {
            seeds,
            albedo,
            waves,
        }
    }

    /// (cluster, reflectance, shading) at scene position (x, y).
    fn at(&self, x: i32, y: i32) -> (u32, [f32; 3], f32) {
        let (fx, fy) = (x as f32, y as f32);
        let k = (0..CLUSTERS)
            .min_by(|&a, &b| {
                let da = (self.seeds[a].0 - fx).powi(2) + (self.seeds[a].1 - fy).powi(2);
                let db = (self.seeds[b].0 - fx).powi(2) + (self.seeds[b].1 - fy).powi(2);
                da.total_cmp(&db)
            })
            .expect("clusters exist");
        let s = 0.55
            + self
                .waves
                .iter()
                .map(|&(kx, ky, ph, amp)| {
                    amp * (std::f32::consts::TAU * (kx * fx + ky * fy) + ph).cos()
                })
                .sum::<f32>();
        // Texture attached to the scene: ±4% of the reflectance, per pixel and channel, so
        // that frames hold tens of thousands of distinct colours as real footage does.
        let mut r = self.albedo[k];
        for (c, v) in r.iter_mut().enumerate() {
            *v *= 1.0 + TEXTURE * (hash(x, 3 * y + c as i32) - 0.5);
        }
        (k as u32, r, s)
    }

    fn frame(&self, dx: i32, dy: i32) -> (Image, Image, Labels) {
        let px: Vec<(u32, [f32; 3], f32)> = (0..H as i32)
            .flat_map(|y| (0..W as i32).map(move |x| (x, y)))
            .map(|(x, y)| self.at(x - dx, y - dy))
            .collect();
        let input = px.iter().flat_map(|&(_, r, s)| r.map(|v| v * s)).collect();
        let refl = px.iter().flat_map(|&(_, r, _)| r).collect();
        let labels = Labels {
            width: W,
            height: H,
            data: px.iter().map(|p| p.0).collect(),
            count: CLUSTERS,
        };
        (
            Image::from_vec(W, H, 3, input).expect("sizes match"),
            Image::from_vec(W, H, 3, refl).expect("sizes match"),
            labels,
        )
    }
}

/// A value in [0, 1) from a scene position (an integer hash).
fn hash(x: i32, y: i32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x9E37_79B1) ^ (y as u32).wrapping_mul(0x85EB_CA77);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> decompose::Result<()> {
    let scene = Scene::new();
    let (input0, refl0, labels0) = scene.frame(0, 0);
    let (input1, _, labels1) = scene.frame(SHIFT.0, SHIFT.1);
    let flow = Flow::from_fn(W, H, |_, _| [SHIFT.0 as f32, SHIFT.1 as f32]);
    let params = PropagateParams::default();
    println!(
        "{W}x{H}, {CLUSTERS} clusters, shift {SHIFT:?}, rayon threads {}",
        rayon::current_num_threads()
    );

    let mut t_tables = Vec::new();
    let mut t_prop = Vec::new();
    let mut t_stop = Vec::new();
    let cpu0 = decompose::process::cpu_seconds().unwrap_or(f64::NAN);
    let mut last = None;
    for _ in 0..5 {
        let t = Instant::now();
        let tables = ClusterTables::from_frame(&input0, &refl0, &labels0)?;
        t_tables.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let p = propagate(&tables, &labels0, &input1, &flow, &params)?;
        t_prop.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let mask = p.assigned_mask();
        let stop: Vec<bool> = PropagateParams::PASS_WINDOWS
            .iter()
            .map(|&m| should_stop(&mask, m, params.alpha))
            .collect::<decompose::Result<_>>()?;
        t_stop.push(t.elapsed().as_secs_f64());
        last = Some((p, stop));
    }
    let cpu = (decompose::process::cpu_seconds().unwrap_or(f64::NAN) - cpu0) / 5.0;
    let (p, stop) = last.expect("ran");
    let correct = p
        .labels
        .data
        .iter()
        .zip(&labels1.data)
        .filter(|(a, b)| **a != Labels::NONE && a == b)
        .count();
    let mut colours: Vec<[u8; 3]> = (0..input1.len())
        .map(|i| decompose::video::propagate::colour8(input1.rgb(i)))
        .collect();
    colours.sort_unstable();
    colours.dedup();
    println!("distinct 8-bit colours in frame t+1: {}", colours.len());
    println!(
        "tables from_frame: {:.3} s median; propagate: {:.3} s median; should_stop x3: {:.4} s",
        median(t_tables),
        median(t_prop),
        median(t_stop)
    );
    println!("CPU per iteration (tables + propagate + stop, all threads): {cpu:.3} s");
    println!(
        "assigned {:.2}%, of which {:.3}% with the true cluster; stop at M = 30/20/10: {stop:?}",
        100.0 * p.assigned_fraction(),
        100.0 * correct as f64 / p.assigned.max(1) as f64
    );
    Ok(())
}
