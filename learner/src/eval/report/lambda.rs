//! Fig. 5.4 — the λ search: held-out accuracy and perplexity against λ with ±1 standard error
//! bars over folds, the uniform metric on the same held-out answers, the one-standard-error
//! limit, and the chosen λ marked and labelled; plus the search as an HTML section (table,
//! rule, warnings, held-out agreement with intervals).

use std::fmt::Write as _;
use std::path::Path;

use plotters::prelude::*;

use super::charts::{ensure_plot_font, plot_err, tick};
use super::html_escape;
use crate::Result;
use crate::metric::cv::CvReport;

const LEARNED: RGBColor = RGBColor(60, 130, 200);
/// Error bars get a colour of their own, so they can be told apart (and counted) in the SVG.
pub const ERROR_BAR: RGBColor = RGBColor(30, 90, 160);
const UNIFORM: RGBColor = RGBColor(150, 150, 150);
const CHOSEN: RGBColor = RGBColor(200, 40, 40);

/// The label drawn beside the chosen λ (also what tests look for).
pub fn chosen_label(cv: &CvReport) -> String {
    format!("chosen λ = {}", lambda_text(cv.chosen))
}

fn lambda_text(l: f64) -> String {
    if l != 0.0 && (l.abs() < 0.01 || l.abs() >= 1e5) {
        format!("{l:.3e}")
    } else {
        format!("{l:.4}")
    }
}

/// One panel's values per row: `(λ, value, low, high)`, and the uniform metric's
/// `(value, low, high)`.
type Panel = (Vec<(f64, f64, f64, f64)>, Option<(f64, f64, f64)>);

/// Fig. 5.4 as SVG text.
pub fn lambda_svg(cv: &CvReport) -> Result<String> {
    ensure_plot_font()?;
    let path = Path::new("lambda.svg");
    let e = plot_err(path);
    // λ = 0 cannot sit on a log axis: draw it a decade below the smallest positive λ.
    let floor = cv
        .rows
        .iter()
        .map(|r| r.lambda)
        .filter(|l| *l > 0.0)
        .fold(f64::INFINITY, f64::min);
    let floor = if floor.is_finite() {
        floor / 10.0
    } else {
        1e-3
    };
    let x = |l: f64| if l > 0.0 { l } else { floor };
    let accuracy: Panel = (
        cv.rows
            .iter()
            .map(|r| {
                let s = r.accuracy_std_error;
                (x(r.lambda), r.accuracy, r.accuracy - s, r.accuracy + s)
            })
            .collect(),
        cv.uniform.as_ref().map(|u| {
            (
                u.accuracy,
                u.accuracy - u.accuracy_std_error,
                u.accuracy + u.accuracy_std_error,
            )
        }),
    );
    // Perplexity is exp(log-loss): the bars are exp(log-loss ± SE), the SE the rule uses.
    let perplexity: Panel = (
        cv.rows
            .iter()
            .map(|r| {
                let (l, s) = (r.log_loss, r.std_error);
                (x(r.lambda), l.exp(), (l - s).exp(), (l + s).exp())
            })
            .collect(),
        cv.uniform.as_ref().map(|u| {
            (
                u.perplexity,
                (u.log_loss - u.std_error).exp(),
                (u.log_loss + u.std_error).exp(),
            )
        }),
    );
    let limit = cv
        .rows
        .iter()
        .min_by(|a, b| a.log_loss.total_cmp(&b.log_loss))
        .map(|r| (r.log_loss + r.std_error).exp());
    let xs: Vec<f64> = accuracy.0.iter().map(|p| p.0).collect();
    let (xmin, xmax) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let (xmin, xmax) = (xmin / 1.5, xmax * 1.5);
    let chosen_x = x(cv.chosen);
    let title = format!(
        "{}-fold cross-validation (grouped by {}), ±1 SE over folds{}",
        cv.folds,
        cv.grouped_by,
        if cv.at_edge {
            " — choice at the grid's edge"
        } else {
            ""
        }
    );
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 440)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
        let root = root
            .titled(&title, ("sans-serif", 18))
            .map_err(|x| e(x.to_string()))?;
        let panels = root.split_evenly((1, 2));
        for (pi, (area, (points, uniform))) in
            panels.iter().zip([&accuracy, &perplexity]).enumerate()
        {
            let y_desc = if pi == 0 {
                "held-out accuracy"
            } else {
                "held-out perplexity"
            };
            let mut ys: Vec<f64> = points.iter().flat_map(|p| [p.2, p.3]).collect();
            ys.extend(uniform.iter().flat_map(|u| [u.1, u.2]));
            let (ymin, ymax) = ys
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &y| {
                    (a.min(y), b.max(y))
                });
            let pad = ((ymax - ymin) * 0.12).max(1e-3);
            let (ylo, yhi) = (ymin - pad, ymax + 2.5 * pad);
            let mut chart = ChartBuilder::on(area)
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(56)
                .build_cartesian_2d((xmin..xmax).log_scale(), ylo..yhi)
                .map_err(|x| e(x.to_string()))?;
            chart
                .configure_mesh()
                .x_label_formatter(&|v| tick(*v))
                .x_desc("λ")
                .y_desc(y_desc)
                .draw()
                .map_err(|x| e(x.to_string()))?;
            if let Some(u) = uniform {
                chart
                    .draw_series(DashedLineSeries::new(
                        vec![(xmin, u.0), (xmax, u.0)],
                        6,
                        4,
                        UNIFORM.stroke_width(2),
                    ))
                    .map_err(|x| e(x.to_string()))?
                    .label("uniform weights (held-out)")
                    .legend(|(x, y)| {
                        PathElement::new(vec![(x, y), (x + 16, y)], UNIFORM.stroke_width(2))
                    });
            }
            if pi == 1
                && let Some(limit) = limit
            {
                chart
                    .draw_series(DashedLineSeries::new(
                        vec![(xmin, limit), (xmax, limit)],
                        2,
                        3,
                        BLACK.mix(0.5).stroke_width(1),
                    ))
                    .map_err(|x| e(x.to_string()))?
                    .label("best + 1 SE (one-SE limit)")
                    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK.mix(0.5)));
            }
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(chosen_x, ylo), (chosen_x, yhi)],
                    CHOSEN.mix(0.6).stroke_width(1),
                )))
                .map_err(|x| e(x.to_string()))?;
            chart
                .draw_series(LineSeries::new(
                    points.iter().map(|p| (p.0, p.1)),
                    LEARNED.stroke_width(2),
                ))
                .map_err(|x| e(x.to_string()))?
                .label("learned (held-out)")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], LEARNED.stroke_width(2))
                });
            // ±1 SE: a stem and two caps per λ (caps a fixed fraction of a decade wide).
            let cap = 1.12;
            chart
                .draw_series(points.iter().flat_map(|&(px, _, lo, hi)| {
                    [
                        vec![(px, lo), (px, hi)],
                        vec![(px / cap, lo), (px * cap, lo)],
                        vec![(px / cap, hi), (px * cap, hi)],
                    ]
                    .map(|v| PathElement::new(v, ERROR_BAR.stroke_width(1)))
                }))
                .map_err(|x| e(x.to_string()))?;
            chart
                .draw_series(
                    points
                        .iter()
                        .map(|p| Circle::new((p.0, p.1), 3, LEARNED.filled())),
                )
                .map_err(|x| e(x.to_string()))?;
            if let Some(p) = points.iter().find(|p| p.0 == chosen_x) {
                chart
                    .draw_series(std::iter::once(Circle::new(
                        (p.0, p.1),
                        6,
                        CHOSEN.stroke_width(2),
                    )))
                    .map_err(|x| e(x.to_string()))?;
            }
            chart
                .draw_series(std::iter::once(Text::new(
                    chosen_label(cv),
                    (chosen_x * 1.15, yhi - 0.6 * pad),
                    ("sans-serif", 14).into_font().color(&CHOSEN),
                )))
                .map_err(|x| e(x.to_string()))?;
            chart
                .configure_series_labels()
                // Accuracy falls and perplexity rises towards large λ: the legend goes where
                // the curve usually is not.
                .position(if pi == 0 {
                    SeriesLabelPosition::LowerLeft
                } else {
                    SeriesLabelPosition::LowerRight
                })
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|x| e(x.to_string()))?;
        }
        root.present().map_err(|x| e(x.to_string()))?;
    }
    Ok(svg)
}

/// The search as an HTML section: warnings first, the held-out agreement with its intervals,
/// the rule's picks and the table (the chosen row marked).
pub fn lambda_html(cv: &CvReport) -> String {
    let mut h = String::from("<h2>Choice of λ</h2>");
    for w in &cv.warnings {
        let _ = write!(
            h,
            "<p class=\"warning\"><strong>Warning:</strong> {}</p>",
            html_escape(&w.to_string())
        );
    }
    if let Some(a) = &cv.agreement {
        let est = |e: &crate::eval::triplets::Estimate| {
            format!("{:.3} [{:.3}, {:.3}]", e.value, e.low, e.high)
        };
        let _ = write!(
            h,
            "<p>Held-out agreement with the answers (each answer predicted by the fold model \
             that did not see it; 95% intervals by bootstrap over {} {}s): learned {}, uniform \
             weights {}, difference {}.</p>",
            a.units,
            html_escape(&a.unit),
            est(&a.learned),
            est(&a.uniform),
            est(&a.difference)
        );
    }
    let _ = write!(
        h,
        "<p>{}, grouped by {}. Minimum of the held-out log-loss at λ = {}; one-standard-error \
         rule: λ = {}; {}.</p>",
        format_args!("{}-fold cross-validation", cv.folds),
        html_escape(&cv.grouped_by),
        cv.minimum.map_or("–".into(), lambda_text),
        cv.one_se.map_or("–".into(), lambda_text),
        html_escape(&chosen_label(cv)),
    );
    h.push_str(
        "<table><tr><th>λ</th><th>log-loss ± SE</th><th>perplexity</th><th>accuracy ± SE</th>\
         <th>non-zero</th><th></th></tr>",
    );
    for r in &cv.rows {
        let chosen = r.lambda == cv.chosen;
        let _ = write!(
            h,
            "<tr{}><td>{}</td><td>{:.4} ± {:.4}</td><td>{:.4}</td><td>{:.4} ± {:.4}</td>\
             <td>{:.1}</td><td style=\"text-align:left\">{}</td></tr>",
            if chosen { " class=\"chosen\"" } else { "" },
            lambda_text(r.lambda),
            r.log_loss,
            r.std_error,
            r.perplexity,
            r.accuracy,
            r.accuracy_std_error,
            r.nonzero,
            if chosen { "← chosen" } else { "" }
        );
    }
    if let Some(u) = &cv.uniform {
        let _ = write!(
            h,
            "<tr><td>uniform</td><td>{:.4} ± {:.4}</td><td>{:.4}</td><td>{:.4} ± {:.4}</td>\
             <td>all</td><td></td></tr>",
            u.log_loss, u.std_error, u.perplexity, u.accuracy, u.accuracy_std_error
        );
    }
    h.push_str("</table>");
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::cv::choice::{CvWarning, Edge};
    use crate::metric::cv::{Baseline, CvRow};

    fn report() -> CvReport {
        let rows: Vec<CvRow> = [(1.0, 0.60, 40.0), (10.0, 0.55, 12.0), (100.0, 0.58, 3.0)]
            .into_iter()
            .map(|(lambda, log_loss, nonzero)| CvRow {
                lambda,
                log_loss,
                perplexity: f64::exp(log_loss),
                accuracy: 0.7,
                accuracy_std_error: 0.01,
                nonzero,
                std_error: 0.02,
                fold_log_loss: vec![log_loss; 5],
                fold_accuracy: vec![0.7; 5],
            })
            .collect();
        CvReport {
            folds: 5,
            grouped_by: "worker".into(),
            rows,
            chosen: 10.0,
            minimum: Some(10.0),
            one_se: Some(10.0),
            extensions: [0, 1],
            at_edge: false,
            warnings: vec![CvWarning::AtEdge {
                edge: Edge::Upper,
                lambda: 100.0,
                extensions: 1,
            }],
            uniform: Some(Baseline {
                log_loss: 0.66,
                perplexity: f64::exp(0.66),
                accuracy: 0.6,
                accuracy_std_error: 0.01,
                std_error: 0.01,
                fold_log_loss: vec![0.66; 5],
                fold_accuracy: vec![0.6; 5],
            }),
            agreement: None,
            evaluations: 0,
        }
    }

    #[test]
    fn chart_marks_the_chosen_lambda_with_error_bars() {
        let cv = report();
        let svg = lambda_svg(&cv).unwrap();
        assert!(svg.contains("chosen λ = 10.0000"), "label missing");
        // Three strokes (stem, two caps) per λ and panel.
        let bars = svg.matches("stroke=\"#1E5AA0\"").count();
        assert_eq!(bars, 3 * cv.rows.len() * 2, "error-bar strokes");
        assert!(svg.contains("uniform weights (held-out)"));
        assert!(svg.contains("one-SE limit"));
    }

    #[test]
    fn html_marks_the_chosen_row_and_shows_warnings() {
        let html = lambda_html(&report());
        assert_eq!(html.matches("class=\"chosen\"").count(), 1);
        assert!(
            html.contains("<td>10.0000</td><td>0.5500 ± 0.0200</td>"),
            "{html}"
        );
        assert!(
            html.contains("Warning:") && html.contains("largest λ"),
            "{html}"
        );
        assert!(html.contains("<td>uniform</td>"));
    }
}
