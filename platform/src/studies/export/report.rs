//! The study's report in its export: `report.json`, the body of `GET
//! /api/v1/admin/studies/ID/report` (tagged with the kind), and `report.csv`, the same numbers
//! one per row for a spreadsheet — for a composition rating the preference rate for condition A,
//! the one-sided t-test against 0.5, its p-value and effect size (§5.7.3, Appendix 5.B), and
//! each worker's rate; for a mash-up study the mean position of the pieces per condition; for
//! an icon-set study the time, deletions and searches per set per condition.
//! The report always counts what it counts (completed, non-rejected HITs), whatever the export
//! options of the other files.

use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::studies::report::{self, StudyReport};
use crate::studies::study::Study;

use super::columns;

/// One `report.csv` row: group, measure, number (empty when absent), text.
fn row(kind: &str, group: &str, measure: &str, value: Option<f64>, text: &str) -> Vec<String> {
    vec![
        kind.into(),
        group.into(),
        measure.into(),
        // Rust's shortest representation that reads back as the same f64, as serde_json
        // writes report.json, so the two files agree to the last digit.
        value.map(|v| v.to_string()).unwrap_or_default(),
        text.into(),
    ]
}

/// The rows of `report.csv`.
pub(super) fn rows(report: &StudyReport) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    match report {
        StudyReport::Triplet => out.push(row(
            "triplet",
            "",
            "note",
            None,
            "a triplet study is summarised by its dashboard (GET \
             /api/v1/admin/studies/ID/dashboard) and its trained metric",
        )),
        StudyReport::CompositionRating(r) => {
            let k = "composition-rating";
            let question = serde_json::to_value(r.question)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default();
            out.push(row(k, "", "question", None, &question));
            out.push(row(k, "", "workers", Some(r.workers as f64), ""));
            out.push(row(k, "", "answers", Some(r.answers as f64), ""));
            out.push(row(k, "", "chose_a", Some(r.chose_a as f64), ""));
            out.push(row(k, "", "mean_rate", r.mean_rate, ""));
            let s = r.stats.as_ref();
            for (measure, v) in [
                ("t", s.map(|s| s.t)),
                ("df", s.map(|s| s.df)),
                ("p", s.map(|s| s.p)),
                ("effect_size", s.map(|s| s.effect_size)),
                ("sd", s.map(|s| s.sd)),
                ("ci_low", s.map(|s| s.ci_low)),
                ("ci_high", s.map(|s| s.ci_high)),
            ] {
                out.push(row(k, "", measure, v, ""));
            }
            if let Some(note) = &r.note {
                out.push(row(k, "", "note", None, note));
            }
            for w in &r.per_worker {
                let group = format!("worker {}", w.worker);
                out.push(row(k, &group, "answers", Some(w.answers as f64), ""));
                out.push(row(k, &group, "chose_a", Some(w.chose_a as f64), ""));
                out.push(row(k, &group, "rate", Some(w.rate), ""));
            }
        }
        StudyReport::Mashup(r) => {
            for c in &r.conditions {
                let (k, g) = ("mashup", c.condition.as_str());
                out.push(row(k, g, "workers", Some(c.workers as f64), ""));
                out.push(row(k, g, "pieces", Some(c.pieces as f64), ""));
                out.push(row(k, g, "searches", Some(c.searches as f64), ""));
                let p = c.position.as_ref();
                for (measure, v) in [
                    ("position_mean", p.map(|p| p.mean)),
                    ("position_half_width", p.map(|p| p.half_width)),
                    ("position_low", p.map(|p| p.low)),
                    ("position_high", p.map(|p| p.high)),
                    ("position_sd", p.map(|p| p.sd)),
                ] {
                    out.push(row(k, g, measure, v, ""));
                }
            }
        }
        StudyReport::Iconset(r) => {
            let k = "iconset";
            out.push(row(k, "", "confidence", Some(r.confidence), ""));
            for c in &r.conditions {
                let g = c.condition.as_str();
                out.push(row(k, g, "workers", Some(c.workers as f64), ""));
                out.push(row(k, g, "sets", Some(c.sets as f64), ""));
                for (prefix, m) in [
                    ("seconds_per_set", &c.seconds_per_set),
                    ("deletions_per_set", &c.deletions_per_set),
                    ("searches_per_set", &c.searches_per_set),
                    ("spread_per_set", &c.spread_per_set),
                ] {
                    let m = m.as_ref();
                    for (name, v) in [
                        ("mean", m.map(|m| m.mean)),
                        ("half_width", m.map(|m| m.half_width)),
                        ("low", m.map(|m| m.low)),
                        ("high", m.map(|m| m.high)),
                        ("sd", m.map(|m| m.sd)),
                    ] {
                        out.push(row(k, g, &format!("{prefix}_{name}"), v, ""));
                    }
                }
            }
        }
    }
    out
}

/// `report.json` and `report.csv` of `study`.
pub(super) async fn files(db: &Db, study: &Study) -> Result<Vec<(String, Vec<u8>)>> {
    let report = report::report(db, study).await?;
    Ok(vec![
        (
            "report.json".into(),
            serde_json::to_vec_pretty(&report).map_err(AppError::internal)?,
        ),
        ("report.csv".into(), columns::REPORT.csv(&rows(&report))?),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::studies::kind::RatingQuestion;
    use crate::studies::rating::{RatingReport, RatingStats, WorkerRate};

    #[test]
    fn every_number_of_a_rating_report_is_a_row_that_reads_back_exactly() {
        let r = RatingReport {
            question: RatingQuestion::Preference,
            workers: 2,
            answers: 7,
            chose_a: 5,
            mean_rate: Some(0.7083333333333333),
            stats: Some(RatingStats {
                t: 1.4,
                df: 1.0,
                p: 0.19755,
                effect_size: 1.0 / 3.0,
                sd: 0.1,
                ci_low: 0.2,
                ci_high: 1.2,
            }),
            note: None,
            per_worker: vec![WorkerRate {
                worker: 12,
                answers: 4,
                chose_a: 3,
                rate: 0.75,
            }],
        };
        let rows = rows(&StudyReport::CompositionRating(r));
        let find = |g: &str, m: &str| {
            rows.iter()
                .find(|r| r[1] == g && r[2] == m)
                .unwrap_or_else(|| panic!("no {g} {m}"))
        };
        assert_eq!(find("", "question")[4], "preference");
        assert_eq!(
            find("", "effect_size")[3].parse::<f64>().unwrap(),
            1.0 / 3.0
        );
        assert_eq!(find("worker 12", "rate")[3], "0.75");
        assert_eq!(find("", "workers")[3], "2");
        assert!(
            rows.iter()
                .all(|r| r.len() == columns::REPORT.columns.len())
        );
    }
}
