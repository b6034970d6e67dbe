//! Why does the video method's propagation stop (issue 20)? The first frames of the
//! `bench --video` synthetic sequence (320×240 unless told, in memory): Retinex and clusters of frame 0,
//! then [`propagate`] frame to frame *without* completion, and per frame the unassigned pixels
//! by cause (colour in no cluster's Parzen ball; no candidate in the window or no source;
//! posterior below ε; ratio below β), the stopping test for M = 30, 20, 10 and the worst 30×30
//! window (with the clusters under it on frame 1).
//!
//! ```text
//! nice -n 5 cargo run --release -p decompose --example video_stop_diag -- 4 [true] [800x600]
//! ```
//!
//! The first argument is the number of frames; `true` uses the true flow (2, 1) instead of
//! TV-L1; `WxH` another frame size; `merged` propagates the clusters merged by mean
//! reflectance whatever their adjacency (single linkage below 0.1) instead.
use decompose::retinex::{self, RetinexParams, Strokes};
use decompose::synthetic::sliding_albedo;
use decompose::video::flow::{Flow, TvL1FlowParams, flow};
use decompose::video::propagate::{
    ClusterTables, PropagateParams, colour8, propagate, should_stop,
};
use decompose::video::segment::{FelzenszwalbParams, MeanMergeParams, reflectance_clusters};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (w, h) = match args.iter().skip(1).find(|a| a.contains('x')) {
        Some(s) => {
            let (a, b) = s.split_once('x').expect("WxH");
            (a.parse().expect("width"), b.parse().expect("height"))
        }
        None => (320u32, 240u32),
    };
    let frames: usize = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(4);
    let true_flow = args.iter().any(|a| a == "true");
    let frame = sliding_albedo(w, h);
    let img0 = frame(0);
    let (d, _) = retinex::decompose(
        &img0,
        None,
        &Strokes::default(),
        &RetinexParams::default(),
        &mut |_| {},
    )
    .unwrap();
    let clusters = reflectance_clusters(
        &d.reflectance,
        &FelzenszwalbParams::default(),
        &MeanMergeParams::default(),
    )
    .unwrap();
    let tables = ClusterTables::from_frame(&img0, &d.reflectance, &clusters).unwrap();
    println!("clusters {}", clusters.count);
    // How many would remain if clusters of nearly one mean reflectance were merged whatever
    // their adjacency (single linkage, Euclidean distance of the means below 0.1)?
    let means: Vec<[f32; 3]> = (0..clusters.count as u32)
        .map(|k| tables.mean_reflectance(k).unwrap_or([0.0; 3]))
        .collect();
    let mut root: Vec<usize> = (0..means.len()).collect();
    fn find(root: &mut [usize], mut i: usize) -> usize {
        while root[i] != i {
            root[i] = root[root[i]];
            i = root[i];
        }
        i
    }
    for a in 0..means.len() {
        for b in a + 1..means.len() {
            let d2: f32 = (0..3).map(|c| (means[a][c] - means[b][c]).powi(2)).sum();
            if d2 < 0.01 {
                let (ra, rb) = (find(&mut root, a), find(&mut root, b));
                root[ra] = rb;
            }
        }
    }
    let groups = (0..means.len())
        .filter(|&i| find(&mut root, i) == i)
        .count();
    println!("groups of clusters with mean reflectance within 0.1 (any adjacency): {groups}");
    // With `merged`: propagate those groups instead of the clusters.
    let (clusters, tables) = if args.iter().any(|a| a == "merged") {
        let mut ids = std::collections::BTreeMap::new();
        let data: Vec<u32> = clusters
            .data
            .iter()
            .map(|&l| {
                let r = find(&mut root, l as usize);
                let next = ids.len() as u32;
                *ids.entry(r).or_insert(next)
            })
            .collect();
        let merged = decompose::Labels {
            width: w,
            height: h,
            data,
            count: ids.len(),
        };
        let tables = ClusterTables::from_frame(&img0, &d.reflectance, &merged).unwrap();
        (merged, tables)
    } else {
        (clusters, tables)
    };
    let pp = PropagateParams::default();
    let mut prev = clusters.clone();
    let mut prev_img = img0;
    for t in 1..frames {
        let img = frame(t);
        let f = if true_flow {
            Flow::from_fn(w, h, |_, _| [2.0, 1.0])
        } else {
            flow(&prev_img, &img, &TvL1FlowParams::fast()).unwrap()
        };
        let m = f.mean();
        let prop = propagate(&tables, &prev, &img, &f, &pp).unwrap();
        let n = (w * h) as usize;
        let (mut nocand, mut zero_post, mut low_eps, mut low_beta) = (0, 0, 0, 0);
        let mut nolik_interior = 0;
        for i in 0..n {
            if prop.labels.data[i] != decompose::Labels::NONE {
                continue;
            }
            let lik = tables.likelihoods(colour8(img.rgb(i)), pp.d);
            if lik.is_empty() {
                nocand += 1;
                let (x, y) = (i as u32 % w, i as u32 / w);
                if x >= 3 && y >= 2 {
                    nolik_interior += 1;
                }
                continue;
            }
            let p = prop.posterior[i] as f64;
            if p == 0.0 {
                zero_post += 1;
            } else if p < pp.epsilon {
                low_eps += 1;
            } else {
                low_beta += 1;
            }
        }
        let un = n - prop.assigned;
        let stop = |mm| should_stop(&prop.assigned_mask(), mm, pp.alpha).unwrap();
        println!(
            "t={t} flow mean ({:.2},{:.2}) unassigned {un} ({:.1}%): colour in no ball {nocand} (interior {nolik_interior}), no cand in window/no source {zero_post}, post<eps {low_eps}, ratio<beta {low_beta}; stop M30 {} M20 {} M10 {}",
            m[0],
            m[1],
            100.0 * un as f64 / n as f64,
            stop(30),
            stop(20),
            stop(10)
        );
        // Windows: where is the worst 30x30 window?
        let mask = prop.assigned_mask();
        let md = mask.data();
        let mut best = (0, 0, 0);
        for y in 0..=(h as usize - 30) {
            for x in 0..=(w as usize - 30) {
                if x % 5 != 0 || y % 5 != 0 {
                    continue;
                }
                let mut c = 0;
                for yy in y..y + 30 {
                    for xx in x..x + 30 {
                        c += usize::from(!md[yy * w as usize + xx]);
                    }
                }
                if c > best.0 {
                    best = (c, x, y);
                }
            }
        }
        println!(
            "   worst 30x30 window at ({}, {}): {} / 900 unassigned",
            best.1, best.2, best.0
        );
        if t == 1 {
            let mut ks = std::collections::BTreeMap::new();
            for yy in best.2..best.2 + 30 {
                for xx in best.1..best.1 + 30 {
                    *ks.entry(prev.data[yy * w as usize + xx]).or_insert(0) += 1;
                }
            }
            for (&k, &c) in &ks {
                if k == decompose::Labels::NONE {
                    continue;
                }
                println!(
                    "   frame0 cluster {k}: {c} px in window, |I_k| {}, mean R {:?}",
                    tables.pixels(k),
                    tables.mean_reflectance(k)
                );
            }
            let (cx, cy) = (best.1 + 15, best.2 + 15);
            let i = cy * w as usize + cx;
            println!(
                "   centre ({cx},{cy}) colour {:?} own {} posterior {} lik {:?}",
                colour8(img.rgb(i)),
                prev.data[i],
                prop.posterior[i],
                tables.likelihoods(colour8(img.rgb(i)), pp.d)
            );
        }
        prev = prop.labels.clone();
        // keep assigned labels only (as the method would, without completion)
        prev_img = img;
    }
}
