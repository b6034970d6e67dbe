//! Tests of the shared pieces, and the temporal stability of every edit.

use super::fixture::{BG, BG_COLOUR, FG, FG_COLOUR, sequence};
use super::*;

#[test]
fn frame_checks_sizes_and_channels() {
    let seq = sequence(false);
    let f = &seq[0];
    assert!(Frame::new(&f.reflectance, &f.shading, &f.labels).is_ok());
    assert!(Frame::new(&f.shading, &f.shading, &f.labels).is_err());
    assert!(Frame::new(&f.reflectance, &f.reflectance, &f.labels).is_err());
    let small = Labels {
        width: 4,
        height: 4,
        data: vec![0; 16],
        count: 1,
    };
    assert!(matches!(
        Frame::new(&f.reflectance, &f.shading, &small),
        Err(Error::ShapeMismatch { .. })
    ));
}

#[test]
fn cluster_means_cover_every_frame_and_skip_unassigned() {
    let seq = sequence(true);
    let frames: Vec<Frame> = seq.iter().map(|f| f.frame()).collect();
    let t = ClusterMeans::from_frames(&frames);
    // Cluster 2 appears after frame 0 only; the table still knows it.
    assert_eq!(t.ids().collect::<Vec<_>>(), vec![0, 1, 2]);
    let assigned: u64 = seq
        .iter()
        .map(|f| f.labels.data.iter().filter(|&&l| l != Labels::NONE).count() as u64)
        .sum();
    assert_eq!(t.count(0) + t.count(1) + t.count(2), assigned);
    for c in 0..3 {
        assert!((t.mean(FG).unwrap()[c] - FG_COLOUR[c]).abs() < 1e-6);
        assert!((t.mean(BG).unwrap()[c] - BG_COLOUR[c]).abs() < 1e-6);
    }
    assert_eq!(t.mean(7), None);
    assert_eq!(t.nearest(2, &[FG, BG]), Some(BG));
}

/// Temporal stability of every edit: on a sequence whose reflectance is constant per cluster,
/// the edited reflectance is constant per cluster, with the same value in every frame.
mod stability {
    use super::super::fixture::{FG, rect, sequence};
    use super::super::*;
    use crate::edit::{Curve, StyliseParams};

    fn assert_constant_per_cluster(name: &str, edited: &[(Decomposition, &Labels)]) {
        let mut value: Vec<Option<[f32; 3]>> = Vec::new();
        for (t, (d, labels)) in edited.iter().enumerate() {
            for (i, &l) in labels.data.iter().enumerate() {
                if l == Labels::NONE {
                    continue;
                }
                if value.len() <= l as usize {
                    value.resize(l as usize + 1, None);
                }
                let r = d.reflectance.rgb(i);
                match value[l as usize] {
                    None => value[l as usize] = Some(r),
                    Some(v) => assert_eq!(v, r, "{name}: cluster {l}, frame {t}, pixel {i}"),
                }
            }
        }
    }

    #[test]
    fn every_edit_keeps_constant_clusters_constant() {
        let seq = sequence(true);
        let frames: Vec<Frame> = seq.iter().map(|f| f.frame()).collect();
        let table = ClusterMeans::from_frames(&frames);
        let first = &frames[0];
        let run = |name: &str, f: &dyn Fn(&Frame) -> Decomposition| {
            let edited: Vec<(Decomposition, &Labels)> =
                frames.iter().map(|fr| (f(fr), fr.labels)).collect();
            assert_constant_per_cluster(name, &edited);
        };
        let rc = recolour::ClusterRecolour::from_scribbles(
            first.labels,
            &table,
            &[recolour::Scribble {
                mask: rect(3, 5, 5, 6),
                target: [0.1, 0.6, 0.2],
            }],
        )
        .unwrap();
        assert_eq!(rc.clusters(), vec![FG]);
        run("recolour", &|f| rc.apply(f));
        let src = Image::from_fn(8, 8, |x, y| [x as f32 / 8.0, y as f32 / 8.0, 0.3]);
        let tr = transfer::ColourTransfer::fit(first, &src).unwrap();
        run("transfer", &|f| tr.apply(f));
        let st = stylise::VideoStylise::fit(first, &StyliseParams::default()).unwrap();
        run("stylise", &|f| st.apply(f));
        let curve = Curve::new(&[(0.0, 0.1), (0.6, 0.4), (1.0, 1.0)]).unwrap();
        let me = material::MaterialEdit::fit(first, curve, None).unwrap();
        run("material", &|f| me.apply(f));
        // The segmentation of a constant sequence is a function of the label alone.
        let seg = segment::StrokeSegmentation::from_strokes(
            first.labels,
            &table,
            &rect(3, 5, 5, 6),
            &rect(0, 2, 0, 2),
        )
        .unwrap();
        for f in &frames {
            let m = seg.mask(f.labels);
            for (i, &l) in f.labels.data.iter().enumerate() {
                assert_eq!(m.at(i), l == FG);
            }
        }
    }
}
