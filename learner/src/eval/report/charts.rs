//! Chart drawing shared by the report's figures: plotters with a registered system font, SVG
//! text rendered to PNG with resvg; Fig. 5.3 (weights) and Fig. 5.5 (learning curve).

use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

use plotters::prelude::*;

use super::CurvePoint;
use crate::Error;
use crate::Result;
use crate::features::{Family, catalogue};
use crate::metric::Model;

pub(super) fn plot_err(path: &Path) -> impl Fn(String) -> Error + '_ {
    move |message| Error::Plot {
        path: path.to_path_buf(),
        message,
    }
}

const FAMILIES: [(Family, &str, RGBColor); 4] = [
    (Family::Colour, "colour", RGBColor(220, 80, 60)),
    (Family::Shading, "shading", RGBColor(240, 170, 40)),
    (Family::Texture, "texture", RGBColor(60, 130, 200)),
    (Family::Stroke, "strokes", RGBColor(80, 160, 90)),
];

/// plotters measures text with ab_glyph, which needs a registered font even for SVG output:
/// register the system's default sans-serif face once (via the same fontdb resvg uses).
pub(super) fn ensure_plot_font() -> Result<()> {
    static DONE: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        let db = fonts();
        let id = db
            .query(&usvg::fontdb::Query {
                families: &[usvg::fontdb::Family::SansSerif],
                ..usvg::fontdb::Query::default()
            })
            .or_else(|| db.faces().next().map(|f| f.id))
            .ok_or("no system font found (install e.g. fonts-dejavu-core)")?;
        let bytes = db
            .with_face_data(id, |data, _| data.to_vec())
            .ok_or("cannot read the system font")?;
        // Registered fonts must live for the whole process.
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        for style in [FontStyle::Normal, FontStyle::Bold] {
            plotters::style::register_font("sans-serif", style, bytes)
                .map_err(|_| "the system font is not a valid TrueType/OpenType font")?;
        }
        Ok(())
    })
    .clone()
    .map_err(|message| Error::Plot {
        path: PathBuf::from("(font)"),
        message,
    })
}

/// Fig. 5.3: SVG text of the weights bar chart, bars grouped by family (features whose names
/// are not in the catalogue go last, in grey).
pub fn weights_svg(model: &Model) -> Result<String> {
    weights_chart(
        model.lambda,
        model.nonzero,
        &model.feature_names,
        &model.weights,
    )
}

/// Width of the weights chart's key, right of the plot: the key never covers a bar.
const KEY_WIDTH: u32 = 130;

/// [`weights_svg`] over its parts.
fn weights_chart(
    lambda: f64,
    nonzero: usize,
    feature_names: &[String],
    weights: &[f64],
) -> Result<String> {
    let cat = catalogue();
    // The catalogue first; names from another version of the extractor by their prefix.
    let family_of = |name: &str| {
        cat.iter()
            .find(|f| f.name == name)
            .map(|f| f.family)
            .or_else(|| match name.split('_').next() {
                Some("colour") => Some(Family::Colour),
                Some("shading") => Some(Family::Shading),
                Some("texture" | "lbp" | "glcm" | "haralick") => Some(Family::Texture),
                Some("stroke" | "swt") => Some(Family::Stroke),
                _ => None,
            })
    };
    let mut bars: Vec<(usize, f64, Option<Family>)> = feature_names
        .iter()
        .zip(weights)
        .map(|(n, &w)| (0, w, family_of(n)))
        .collect();
    let rank = |f: Option<Family>| FAMILIES.iter().position(|x| Some(x.0) == f).unwrap_or(4);
    bars.sort_by_key(|b| rank(b.2));
    for (i, b) in bars.iter_mut().enumerate() {
        b.0 = i;
    }
    ensure_plot_font()?;
    let top = bars.iter().map(|b| b.1).fold(0.0f64, f64::max).max(1e-6) * 1.1;
    let path = Path::new("weights.svg");
    let e = plot_err(path);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
        let (plot, key) = root.split_horizontally(1000 - KEY_WIDTH);
        let mut chart = ChartBuilder::on(&plot)
            .caption(
                format!(
                    "Learned weights (λ = {:.3}, {} of {} non-zero)",
                    lambda,
                    nonzero,
                    weights.len()
                ),
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d(0f64..bars.len() as f64, 0f64..top)
            .map_err(|x| e(x.to_string()))?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_label_formatter(&|x| format!("{x:.0}"))
            .x_desc("feature (grouped by family)")
            .y_desc("weight w")
            .draw()
            .map_err(|x| e(x.to_string()))?;
        let mut groups: Vec<(Option<Family>, &str, RGBColor)> = FAMILIES
            .iter()
            .map(|(f, n, c)| (Some(*f), *n, *c))
            .collect();
        groups.push((None, "other", RGBColor(150, 150, 150)));
        let mut shown = 0;
        for (fam, name, colour) in groups {
            let mine: Vec<_> = bars.iter().filter(|b| b.2 == fam).collect();
            if mine.is_empty() {
                continue;
            }
            chart
                .draw_series(mine.iter().map(|b| {
                    Rectangle::new(
                        [(b.0 as f64 + 0.1, 0.0), (b.0 as f64 + 0.9, b.1)],
                        colour.filled(),
                    )
                }))
                .map_err(|x| e(x.to_string()))?;
            // The key sits in its own column right of the plot (plotters' series labels go
            // inside the plot, over the first bars).
            let y = 60 + 24 * shown;
            key.draw(&Rectangle::new([(8, y - 6), (20, y + 6)], colour.filled()))
                .map_err(|x| e(x.to_string()))?;
            key.draw(&Text::new(
                name,
                (28, y - 7),
                ("sans-serif", 15).into_font().color(&BLACK),
            ))
            .map_err(|x| e(x.to_string()))?;
            shown += 1;
        }
        root.present().map_err(|x| e(x.to_string()))?;
    }
    Ok(svg)
}

/// Axis tick text: integers without a fraction, small values with two significant digits.
pub(super) fn tick(x: f64) -> String {
    if x.abs() >= 10.0 || x == x.round() {
        format!("{x:.0}")
    } else {
        format!("{x:.2}")
    }
}

/// A named line: colour and `(x, accuracy, perplexity)` points.
type Series<'a> = (&'a str, RGBColor, Vec<(f64, f64, f64)>);

/// Two panels (accuracy, perplexity) of `series` against `x`.
fn two_panel_svg(title: &str, x_desc: &str, log_x: bool, series: &[Series<'_>]) -> Result<String> {
    ensure_plot_font()?;
    let path = Path::new("chart.svg");
    let e = plot_err(path);
    let xs: Vec<f64> = series
        .iter()
        .flat_map(|s| s.2.iter().map(|p| p.0))
        .collect();
    let (xmin, xmax) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let (xmin, xmax) = if log_x {
        (xmin / 1.3, xmax * 1.3)
    } else {
        (xmin, xmax + 1e-9)
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
        let root = root
            .titled(title, ("sans-serif", 20))
            .map_err(|x| e(x.to_string()))?;
        let panels = root.split_evenly((1, 2));
        for (pi, panel) in panels.iter().enumerate() {
            let pick = |p: &(f64, f64, f64)| if pi == 0 { p.1 } else { p.2 };
            let ys: Vec<f64> = series.iter().flat_map(|s| s.2.iter().map(pick)).collect();
            let (ymin, ymax) = ys
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &y| {
                    (a.min(y), b.max(y))
                });
            let pad = ((ymax - ymin) * 0.1).max(1e-3);
            let (ylo, yhi) = (ymin - pad, ymax + pad);
            let y_desc = if pi == 0 { "accuracy" } else { "perplexity" };
            let mut builder = ChartBuilder::on(panel);
            builder
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(56);
            macro_rules! draw {
                ($chart:expr) => {{
                    let mut chart = $chart.map_err(|x| e(x.to_string()))?;
                    chart
                        .configure_mesh()
                        .x_label_formatter(&|x| tick(*x))
                        .x_desc(x_desc)
                        .y_desc(y_desc)
                        .draw()
                        .map_err(|x| e(x.to_string()))?;
                    for (name, colour, pts) in series {
                        let colour = *colour;
                        let line: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, pick(p))).collect();
                        chart
                            .draw_series(LineSeries::new(line.clone(), colour.stroke_width(2)))
                            .map_err(|x| e(x.to_string()))?
                            .label(*name)
                            .legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2))
                            });
                        chart
                            .draw_series(line.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                            .map_err(|x| e(x.to_string()))?;
                    }
                    chart
                        .configure_series_labels()
                        .background_style(WHITE.mix(0.8))
                        .border_style(BLACK)
                        .draw()
                        .map_err(|x| e(x.to_string()))?;
                }};
            }
            if log_x {
                draw!(builder.build_cartesian_2d((xmin..xmax).log_scale(), ylo..yhi));
            } else {
                draw!(builder.build_cartesian_2d(xmin..xmax, ylo..yhi));
            }
        }
        root.present().map_err(|x| e(x.to_string()))?;
    }
    Ok(svg)
}

/// Fig. 5.5: test accuracy and perplexity against the number of training triplets.
pub fn curve_svg(points: &[CurvePoint]) -> Result<String> {
    let learned = points
        .iter()
        .map(|p| (p.triplets as f64, p.accuracy, p.perplexity))
        .collect();
    let uniform = points
        .iter()
        .map(|p| (p.triplets as f64, p.uniform_accuracy, p.uniform_perplexity))
        .collect();
    two_panel_svg(
        "Learning curve (test triplets)",
        "training triplets",
        true,
        &[
            ("learned", RGBColor(60, 130, 200), learned),
            ("uniform", RGBColor(150, 150, 150), uniform),
        ],
    )
}

fn fonts() -> Arc<usvg::fontdb::Database> {
    static FONTS: OnceLock<Arc<usvg::fontdb::Database>> = OnceLock::new();
    FONTS
        .get_or_init(|| {
            let mut db = usvg::fontdb::Database::new();
            db.load_system_fonts();
            // fontdb maps the generic `sans-serif` to Arial, which Linux rarely has: point it
            // at an installed sans face so chart text renders.
            let sans = usvg::fontdb::Query {
                families: &[usvg::fontdb::Family::SansSerif],
                ..usvg::fontdb::Query::default()
            };
            if db.query(&sans).is_none() {
                let has = |name: &str| {
                    db.faces()
                        .any(|f| f.families.iter().any(|(n, _)| n == name))
                };
                let pick = ["DejaVu Sans", "Liberation Sans", "Noto Sans", "FreeSans"]
                    .into_iter()
                    .find(|n| has(n))
                    .map(str::to_owned)
                    .or_else(|| {
                        db.faces()
                            .next()
                            .and_then(|f| f.families.first().map(|x| x.0.clone()))
                    });
                if let Some(name) = pick {
                    db.set_sans_serif_family(name);
                }
            }
            Arc::new(db)
        })
        .clone()
}

/// Renders chart SVG text to PNG bytes at its own size on white.
pub fn svg_to_png(svg: &str, path: &Path) -> Result<Vec<u8>> {
    let e = plot_err(path);
    let options = usvg::Options {
        fontdb: fonts(),
        ..usvg::Options::default()
    };
    let tree = usvg::Tree::from_str(svg, &options).map_err(|x| e(x.to_string()))?;
    let size = tree.size().to_int_size();
    let mut pixmap = tiny_skia::Pixmap::new(size.width(), size.height())
        .ok_or_else(|| e("empty chart".into()))?;
    pixmap.fill(tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        tiny_skia::Transform::identity(),
        &mut pixmap.as_mut(),
    );
    pixmap.encode_png().map_err(|x| e(x.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The numeric attribute `name="…"` of an SVG element's text.
    fn attr(element: &str, name: &str) -> Option<f64> {
        let at = element.find(&format!(" {name}=\""))? + name.len() + 3;
        element[at..].split('"').next()?.parse().ok()
    }

    /// Issue 16: the key of the weights chart covered the first bars. With a weight on every
    /// feature, every family's label must lie right of every bar.
    #[test]
    fn the_weights_key_covers_no_bar() {
        let names: Vec<String> = catalogue().iter().map(|f| f.name.to_string()).collect();
        let weights = vec![1.0; names.len()];
        let svg = weights_chart(1.0, names.len(), &names, &weights).expect("chart");
        let bars_right = svg
            .split("<rect")
            .skip(1)
            .filter(|r| attr(r, "height").is_some_and(|h| h > 14.0))
            .filter(|r| attr(r, "width").is_some_and(|w| w < 100.0))
            .map(|r| attr(r, "x").unwrap_or(0.0) + attr(r, "width").unwrap_or(0.0))
            .fold(0.0f64, f64::max);
        assert!(bars_right > 500.0, "bars found up to x = {bars_right}");
        for label in ["colour", "shading", "texture", "strokes"] {
            let text = svg
                .split("<text")
                .find(|t| {
                    let body = t.split('>').nth(1).unwrap_or("");
                    body.split('<').next().unwrap_or("").trim() == label
                })
                .unwrap_or_else(|| panic!("no key entry {label}"));
            let x = attr(text, "x").expect("text x");
            assert!(
                x > bars_right,
                "{label} at x = {x}, bars reach {bars_right}"
            );
        }
    }
}
