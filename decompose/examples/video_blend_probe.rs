//! Which per-frame single-image decompositions to blend in step 8 of the video method (issue
//! 20, twelfth session; `docs/video-data.md`, "Twelfth session"). A probe kept so that the
//! figures there can be reproduced, not a tool:
//!
//! ```text
//! cargo run --release -p decompose --example video_blend_probe -- members SEQ_DIR CACHE_DIR
//! cargo run --release -p decompose --example video_blend_probe -- grid SEQ_DIR CACHE_DIR > grid.tsv
//! ```
//!
//! `members` computes every member's shading of every frame of a rendered sequence (the video
//! method with and without step 8, the single view, Zhao's Retinex and the clustering method at
//! full and half resolution) and the TV-L1 flow back to the previous frame, as raw f32 files in
//! `CACHE_DIR`; `grid` scores blends of the cached members (step 8's blend and average along
//! the flow) and prints one line per setting: sequence, setting, mean LMSE, flicker (the true
//! flow). `time SEQ_DIR -` and `synth - -` time the members on an 800×600 frame (a rendered
//! one scaled up; the synthetic `bench --video` sequence).
//!
//! Thirteenth session: `MEDIAN=1 … grid` scores only the default's blend with 0, half or all of
//! it replaced by the per-pixel median of its members; `MEDIAN=2 … grid`, the median over more
//! members (Zhao's Retinex and the clustering method at half size) with the default's mean;
//! `MEDIAN=3 … grid`, the members' weights again under the half median.

use std::path::{Path, PathBuf};

use decompose::Image;
use decompose::lightfield::LightField;
use decompose::video::baseline::PerFrameMethod;
use decompose::video::flow::{Flow, TvL1FlowParams, flow};
use decompose::video::method::{FusionParams, OwnedFrame, VideoParams, decompose_video};
use decompose::video::score::SequenceScorer;
use decompose::video::truth::load_truth;

const MEMBERS: [&str; 7] = ["ours", "prop", "view", "ret", "reth", "clu", "cluh"];

type Res<T> = Result<T, Box<dyn std::error::Error>>;

fn grey(img: &Image) -> Vec<f32> {
    let c = img.channels();
    (0..img.len())
        .map(|i| img.px(i).iter().sum::<f32>() / c as f32)
        .collect()
}

fn save(path: &Path, v: &[f32]) -> Res<()> {
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(path, bytes)?;
    Ok(())
}

fn load(path: &Path) -> Res<Vec<f32>> {
    let b = std::fs::read(path)?;
    Ok(b.chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect())
}

fn half(frame: &Image, m: &PerFrameMethod) -> Res<Vec<f32>> {
    let (w, h) = frame.dims();
    let small = frame.resize(w / 2, h / 2);
    let (d, _) = m.decompose(&small)?;
    Ok(grey(&d.shading.resize(w, h)))
}

fn members(seq: &Path, cache: &Path) -> Res<()> {
    std::fs::create_dir_all(cache)?;
    let truth = load_truth(seq)?;
    let n = truth.len();
    let src = truth.input_frames();
    let scratch = cache.join("scratch");
    for (name, params) in [
        ("ours", VideoParams::default()),
        (
            "prop",
            VideoParams {
                fusion: Some(FusionParams {
                    beta: 1e-6,
                    clustering_weight: 0.0,
                    alpha: 1.0,
                    ..Default::default()
                }),
                ..Default::default()
            },
        ),
    ] {
        if cache.join(format!("{name}_{:03}.f32", n - 1)).exists() {
            continue;
        }
        let _ = std::fs::remove_dir_all(&scratch);
        std::fs::create_dir_all(&scratch)?;
        let mut out: Vec<OwnedFrame> = Vec::new();
        decompose_video(
            src,
            &Default::default(),
            &params,
            &scratch,
            &mut out,
            &mut |_| {},
        )?;
        for f in &out {
            save(
                &cache.join(format!("{name}_{:03}.f32", f.index)),
                &grey(&f.shading),
            )?;
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
    let view = FusionParams::default().view;
    let ret = PerFrameMethod::retinex();
    let clu = PerFrameMethod::clustering();
    for t in 0..n {
        if cache.join(format!("cluh_{t:03}.f32")).exists() {
            continue;
        }
        let frame = src.frame(t)?;
        let (w, h) = frame.dims();
        let lf = LightField::from_vec(1, 1, w, h, 3, frame.data().to_vec())?;
        let (d, _) = decompose::lightfield::decompose(&lf, None, &view, &mut |_| {})?;
        save(
            &cache.join(format!("view_{t:03}.f32")),
            d.shading.view_data(0),
        )?;
        save(
            &cache.join(format!("ret_{t:03}.f32")),
            &grey(&ret.decompose(&frame)?.0.shading),
        )?;
        save(
            &cache.join(format!("reth_{t:03}.f32")),
            &half(&frame, &ret)?,
        )?;
        save(
            &cache.join(format!("clu_{t:03}.f32")),
            &grey(&clu.decompose(&frame)?.0.shading),
        )?;
        save(
            &cache.join(format!("cluh_{t:03}.f32")),
            &half(&frame, &clu)?,
        )?;
        if t > 0 {
            let prev = src.frame(t - 1)?;
            let b = flow(&frame, &prev, &TvL1FlowParams::fast())?;
            let mut uv = b.u().to_vec();
            uv.extend_from_slice(b.v());
            save(&cache.join(format!("back_{t:03}.f32")), &uv)?;
        }
    }
    Ok(())
}

fn median(mut v: Vec<f32>) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let k = v.len() / 2;
    *v.select_nth_unstable_by(k, f32::total_cmp).1
}

/// The median, the mean of the middle two for an even count (as `fusion::blend`).
fn middle(mut v: Vec<f32>) -> f32 {
    v.sort_by(f32::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// One blend: weights per member (index into MEMBERS), α, gate.
struct Setting {
    name: String,
    weights: Vec<(usize, f32)>,
    alpha: f32,
    gate: f32,
    /// Weight of the per-pixel median of the (shifted) members in `weights` against their
    /// weighted mean (thirteenth session): 0 is the weighted mean of step 8.
    median_share: f32,
    /// Members (index into MEMBERS) in the median besides those of `weights`.
    median_extra: Vec<usize>,
}

fn settings() -> Vec<Setting> {
    if std::env::var("MEDIAN").is_ok_and(|m| m == "3") {
        // Thirteenth session, fourth rule: the members' weights again, under the median.
        let mut out = Vec::new();
        for wp in [0.3f32, 0.4, 0.5, 0.6] {
            for wc in [0.1f32, 0.2, 0.3] {
                let wv = 1.0 - wp - wc;
                if wv < 0.1 - 1e-6 {
                    continue;
                }
                out.push(Setting {
                    name: format!("prop={wp:.2},view={wv:.2},clu={wc:.2} a=0.1 med=0.5"),
                    weights: vec![(1, wp), (2, wv), (5, wc)],
                    alpha: 0.1,
                    gate: 0.1,
                    median_share: 0.5,
                    median_extra: Vec::new(),
                });
            }
        }
        return out;
    }
    if std::env::var("MEDIAN").is_ok_and(|m| m == "2") {
        // Thirteenth session, second rule: more members in the median only (the mean keeps
        // the default's three).
        let mut out = Vec::new();
        for (extra, shares) in [
            (vec![], &[0.5f32][..]),
            (vec![4], &[0.5, 1.0][..]),
            (vec![6], &[0.5, 1.0][..]),
            (vec![4, 6], &[0.5, 1.0][..]),
            (vec![3], &[0.5][..]),
        ] {
            for &share in shares {
                let names: Vec<&str> = extra.iter().map(|&m| MEMBERS[m]).collect();
                out.push(Setting {
                    name: format!(
                        "prop=0.50,view=0.40,clu=0.10 a=0.1 med={share} extra={}",
                        names.join("+")
                    ),
                    weights: vec![(1, 0.5), (2, 0.4), (5, 0.1)],
                    alpha: 0.1,
                    gate: 0.1,
                    median_share: share,
                    median_extra: extra.clone(),
                });
            }
        }
        return out;
    }
    if std::env::var("MEDIAN").is_ok() {
        // Thirteenth session: the default blend, the median of its three members, and half
        // of each (`/work/exp/s13/prereg.txt`).
        return [0.0f32, 0.5, 1.0]
            .into_iter()
            .map(|share| Setting {
                name: format!("prop=0.50,view=0.40,clu=0.10 a=0.1 med={share}"),
                weights: vec![(1, 0.5), (2, 0.4), (5, 0.1)],
                alpha: 0.1,
                gate: 0.1,
                median_share: share,
                median_extra: Vec::new(),
            })
            .collect();
    }
    let mut out = Vec::new();
    let mut add = |weights: Vec<(usize, f32)>, alpha: f32| {
        let name = weights
            .iter()
            .filter(|(_, w)| *w > 0.0)
            .map(|(m, w)| format!("{}={w:.2}", MEMBERS[*m]))
            .collect::<Vec<_>>()
            .join(",");
        out.push(Setting {
            name: format!("{name} a={alpha}"),
            weights,
            alpha,
            gate: 0.1,
            median_share: 0.0,
            median_extra: Vec::new(),
        });
    };
    for m in 0..MEMBERS.len() {
        add(vec![(m, 1.0)], 1.0);
    }
    add(vec![(1, 0.5), (2, 0.5)], 0.1);
    let alpha: f32 = std::env::var("ALPHA")
        .ok()
        .and_then(|a| a.parse().ok())
        .unwrap_or(0.1);
    for extra in 3..MEMBERS.len() {
        for wx in [0.1f32, 0.2, 0.3, 0.4, 0.5] {
            for wp in [0.2f32, 0.3, 0.4, 0.5] {
                let wv = 1.0 - wp - wx;
                if wv < -1e-6 {
                    continue;
                }
                add(vec![(1, wp), (2, wv.max(0.0)), (extra, wx)], alpha);
            }
        }
    }
    for a in [0.05f32, 0.2, 0.3] {
        add(vec![(1, 0.5), (2, 0.5)], a);
        add(vec![(1, 0.5), (2, 0.3), (3, 0.2)], a);
        add(vec![(1, 0.5), (2, 0.3), (4, 0.2)], a);
    }
    for m in 2..MEMBERS.len() {
        add(vec![(m, 1.0)], 0.1);
    }
    for wx in [0.2f32, 0.3, 0.4, 0.5, 0.6] {
        for x in [3usize, 4, 5, 6] {
            add(vec![(1, 1.0 - wx), (x, wx)], 0.1);
        }
    }
    for (a, b) in [(3, 5), (3, 6), (4, 6), (4, 5)] {
        for wx in [0.1f32, 0.2] {
            for wp in [0.3f32, 0.4] {
                let wv = 1.0 - wp - 2.0 * wx;
                add(vec![(1, wp), (2, wv), (a, wx), (b, wx)], alpha);
            }
        }
    }
    out
}

fn grid(seq: &Path, cache: &Path) -> Res<()> {
    let truth = load_truth(seq)?;
    let n = truth.len();
    let name = seq.file_name().map_or_else(
        || seq.display().to_string(),
        |n| n.to_string_lossy().to_string(),
    );
    let (w, h) = truth.size();
    let frames: Vec<Image> = (0..n).map(|t| truth.input(t)).collect::<Result<_, _>>()?;
    let tr: Vec<(Image, Image)> = (0..n)
        .map(|t| Ok((truth.reflectance(t)?, truth.shading(t)?)))
        .collect::<Res<_>>()?;
    let flows: Vec<Flow> = (0..n - 1)
        .map(|t| truth.flow(t))
        .collect::<Result<_, _>>()?;
    let mut mem: Vec<Vec<Vec<f32>>> = Vec::new();
    for m in MEMBERS {
        mem.push(
            (0..n)
                .map(|t| load(&cache.join(format!("{m}_{t:03}.f32"))))
                .collect::<Res<_>>()?,
        );
    }
    let back: Vec<Option<Flow>> = (0..n)
        .map(|t| -> Res<Option<Flow>> {
            if t == 0 {
                return Ok(None);
            }
            let uv = load(&cache.join(format!("back_{t:03}.f32")))?;
            let np = (w * h) as usize;
            Ok(Some(Flow::from_vecs(
                w,
                h,
                uv[..np].to_vec(),
                uv[np..].to_vec(),
            )?))
        })
        .collect::<Res<_>>()?;
    let log_i: Vec<Vec<f32>> = frames
        .iter()
        .map(|f| {
            (0..f.len())
                .map(|i| {
                    let m = f.px(i).iter().sum::<f32>() / 3.0;
                    if m > 0.0 { m.ln() } else { f32::NAN }
                })
                .collect()
        })
        .collect();
    let ln = |v: f32| v.max(f32::MIN_POSITIVE).ln();
    let ww = w as usize;
    let hh = h as usize;
    for s in settings() {
        let mut scorer = SequenceScorer::new();
        let mut prev: Option<(Vec<f32>, Vec<f32>)> = None;
        for t in 0..n {
            let li = &log_i[t];
            let reference = &mem[1][t];
            let mut sb = vec![0.0f32; li.len()];
            let mut shifted: Vec<Vec<f32>> = Vec::new();
            // The median of ln s_m − ln s_prop over the lit pixels.
            let shift_of = |sm: &[f32]| {
                median(
                    sm.iter()
                        .zip(reference)
                        .zip(li)
                        .filter(|(_, l)| l.is_finite())
                        .map(|((&a, &b), _)| ln(a) - ln(b))
                        .collect(),
                )
            };
            for &(m, wt) in &s.weights {
                if wt == 0.0 {
                    continue;
                }
                let sm = &mem[m][t];
                let shift = if m == 1 || s.weights.len() == 1 {
                    0.0
                } else {
                    shift_of(sm)
                };
                for (o, &v) in sb.iter_mut().zip(sm) {
                    *o += wt * (ln(v) - shift);
                }
                if s.median_share > 0.0 {
                    shifted.push(sm.iter().map(|&v| ln(v) - shift).collect());
                }
            }
            for &m in &s.median_extra {
                let sm = &mem[m][t];
                let shift = shift_of(sm);
                shifted.push(sm.iter().map(|&v| ln(v) - shift).collect());
            }
            if s.median_share > 0.0 {
                for (p, o) in sb.iter_mut().enumerate() {
                    let mid = middle(shifted.iter().map(|m| m[p]).collect());
                    *o = (1.0 - s.median_share) * *o + s.median_share * mid;
                }
            }
            let d: Vec<f32> = li.iter().zip(&sb).map(|(i, s)| i - s).collect();
            let fused = match (&prev, &back[t]) {
                (Some((pd, pi)), Some(b)) if s.alpha < 1.0 => {
                    let sample = |data: &[f32], x: f32, y: f32| -> Option<f32> {
                        if !(x >= 0.0 && y >= 0.0 && x <= (ww - 1) as f32 && y <= (hh - 1) as f32) {
                            return None;
                        }
                        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
                        let (x1, y1) = ((x0 + 1).min(ww - 1), (y0 + 1).min(hh - 1));
                        let (tx, ty) = (x - x0 as f32, y - y0 as f32);
                        let at = |xx: usize, yy: usize| data[yy * ww + xx];
                        let v = (at(x0, y0) * (1.0 - tx) + at(x1, y0) * tx) * (1.0 - ty)
                            + (at(x0, y1) * (1.0 - tx) + at(x1, y1) * tx) * ty;
                        v.is_finite().then_some(v)
                    };
                    (0..d.len())
                        .map(|p| {
                            if !li[p].is_finite() {
                                return d[p];
                            }
                            let (x, y) = ((p % ww) as f32 + b.u()[p], (p / ww) as f32 + b.v()[p]);
                            match (sample(pd, x, y), sample(pi, x, y)) {
                                (Some(a), Some(pv)) if (pv - li[p]).abs() <= s.gate => {
                                    (1.0 - s.alpha) * a + s.alpha * d[p]
                                }
                                _ => d[p],
                            }
                        })
                        .collect()
                }
                _ => d,
            };
            let shading: Vec<f32> = li
                .iter()
                .zip(&fused)
                .zip(reference)
                .map(|((&l, &f), &r)| if l.is_finite() { (l - f).exp() } else { r })
                .collect();
            let frame = &frames[t];
            let refl: Vec<f32> = (0..frame.len())
                .flat_map(|i| {
                    let sh = shading[i].max(1e-6);
                    frame.px(i).iter().map(move |&c| c / sh).collect::<Vec<_>>()
                })
                .collect();
            let refl = Image::from_vec(w, h, 3, refl)?;
            let sh_img = Image::from_vec(w, h, 1, shading)?;
            scorer.push(
                &refl,
                &sh_img,
                Some((&tr[t].0, &tr[t].1)),
                if t > 0 { Some(&flows[t - 1]) } else { None },
            )?;
            prev = Some((fused, li.clone()));
        }
        let sc = scorer.finish();
        println!("{name}\t{}\t{:.5}\t{:.5}", s.name, sc.lmse, sc.flicker);
    }
    Ok(())
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        return Err("usage: video_blend_probe members|grid|time|synth SEQ_DIR CACHE_DIR".into());
    }
    let (seq, cache) = (PathBuf::from(&args[2]), PathBuf::from(&args[3]));
    match args[1].as_str() {
        "members" => members(&seq, &cache),
        "grid" => grid(&seq, &cache),
        "synth" => {
            let frame_at = decompose::synthetic::sliding_albedo(800, 600);
            let p = decompose::clustering::ClusteringParams::default();
            for t in [0usize, 30, 60] {
                let f = frame_at(t);
                let o = decompose::clustering::decompose(&f, None, &p, &mut |_| {})?;
                println!(
                    "t {t}: {:?} clusters {} segments {}",
                    o.info.timings, o.info.clusters, o.info.segments
                );
                let view = FusionParams::default().view;
                let t0 = std::time::Instant::now();
                let lf = LightField::from_vec(1, 1, 800, 600, 3, f.data().to_vec())?;
                decompose::lightfield::decompose(&lf, None, &view, &mut |_| {})?;
                println!("view {:.3}", t0.elapsed().as_secs_f64());
            }
            Ok(())
        }
        "time" => {
            let truth = load_truth(&seq)?;
            let f = truth.input(0)?.resize(800, 600);
            let view = FusionParams::default().view;
            for (name, img) in [("800x600", f.clone()), ("400x300", f.resize(400, 300))] {
                for m in [PerFrameMethod::retinex(), PerFrameMethod::clustering()] {
                    let t0 = std::time::Instant::now();
                    m.decompose(&img)?;
                    println!("{name} {} {:.3} s", m.name(), t0.elapsed().as_secs_f64());
                }
                let t0 = std::time::Instant::now();
                let (w, h) = img.dims();
                let lf = LightField::from_vec(1, 1, w, h, 3, img.data().to_vec())?;
                decompose::lightfield::decompose(&lf, None, &view, &mut |_| {})?;
                println!("{name} view {:.3} s", t0.elapsed().as_secs_f64());
            }
            Ok(())
        }
        _ => Err("the first argument is members, grid, time or synth".into()),
    }
}
