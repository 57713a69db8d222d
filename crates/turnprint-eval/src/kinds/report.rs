//! The tables of the evaluation over every kind: merging per kind (cases,
//! rank-1, top-5, ROC AUC against negatives of every other kind), and loops
//! per kind and input (events covered and rank-1, turnprint beside the
//! naive baseline).

use std::fmt::Write;

use serde::Serialize;

use super::loops::{Input, LoopRun, OnlineRun};
use super::merge::{How, MergeCase, Negative};
use super::Kind;
use crate::auc::roc_auc;

/// Everything one run of the evaluation produced.
#[derive(Debug, Default, Serialize)]
pub struct KindsReport {
    /// Seed of every draw.
    pub seed: u64,
    /// Sessions read per kind.
    pub sessions: Vec<(Kind, usize)>,
    /// Files left out, with the reason.
    pub skipped: Vec<(String, String)>,
    /// Every positive merge case that was run.
    pub cases: Vec<MergeCase>,
    /// Draws no single similarity passes, per kind and how.
    pub unattainable: Vec<(Kind, How)>,
    /// Every negative pair.
    pub negatives: Vec<Negative>,
    /// Every loop run, both methods in each.
    pub loops: Vec<LoopRun>,
}

/// One row per kind, then one for all (`None`).
fn rows() -> impl Iterator<Item = (&'static str, Option<Kind>)> {
    let kinds = Kind::ALL.into_iter().map(|k| (k.name(), Some(k)));
    kinds.chain(std::iter::once(("all", None)))
}

fn pct(n: usize, d: usize) -> String {
    match d {
        0 => "-".into(),
        _ => format!("{:.1} %", 100.0 * n as f64 / d as f64),
    }
}

impl KindsReport {
    /// The merge table: one row per kind and one for all.
    pub fn merge_table(&self) -> String {
        let mut out = String::from(
            "| kind | sessions | cases (windows + session pairs) | rank-1 | top-5 | AUC | rank-1 wrong and turned over | unattainable |\n\
             |---|--:|--:|--:|--:|--:|--:|--:|\n",
        );
        for (name, kind) in rows() {
            let of = |k: Kind| kind.is_none_or(|x| x == k);
            let cases: Vec<&MergeCase> = self.cases.iter().filter(|c| of(c.kind)).collect();
            let sessions: usize = self
                .sessions
                .iter()
                .filter(|(k, _)| of(*k))
                .map(|(_, n)| n)
                .sum();
            if cases.is_empty() && sessions == 0 {
                continue;
            }
            let windows = cases.iter().filter(|c| c.how == How::Window).count();
            let count = |f: &dyn Fn(&MergeCase) -> bool| cases.iter().filter(|c| f(c)).count();
            let positives: Vec<f64> = cases.iter().map(|c| c.rank1_score).collect();
            let negatives: Vec<f64> = self
                .negatives
                .iter()
                .filter(|n| of(n.a_kind) || of(n.b_kind))
                .map(|n| n.rank1_score)
                .collect();
            let auc = match positives.is_empty() || negatives.is_empty() {
                true => "-".to_string(),
                false => format!("{:.3}", roc_auc(&positives, &negatives)),
            };
            let unattainable = self.unattainable.iter().filter(|(k, _)| of(*k)).count();
            let _ = writeln!(
                out,
                "| {name} | {sessions} | {} ({windows} + {}) | {} | {} | {auc} | {} | {unattainable} |",
                cases.len(),
                cases.len() - windows,
                pct(count(&|c| c.rank1_correct), cases.len()),
                pct(count(&|c| c.top5_correct), cases.len()),
                count(&|c| c.rank1_flipped),
            );
        }
        out
    }

    /// The merge table split by how B relates to A, per kind.
    pub fn merge_by_how(&self) -> String {
        let mut out =
            String::from("| kind | how | cases | rank-1 | top-5 |\n|---|---|--:|--:|--:|\n");
        for kind in Kind::ALL {
            for how in [How::Window, How::Sessions] {
                let cases: Vec<&MergeCase> = self
                    .cases
                    .iter()
                    .filter(|c| c.kind == kind && c.how == how)
                    .collect();
                if cases.is_empty() {
                    continue;
                }
                let count = |f: &dyn Fn(&MergeCase) -> bool| cases.iter().filter(|c| f(c)).count();
                let how = match how {
                    How::Window => "windows of one session",
                    How::Sessions => "two sessions in one frame",
                };
                let _ = writeln!(
                    out,
                    "| {} | {how} | {} | {} | {} |",
                    kind.name(),
                    cases.len(),
                    pct(count(&|c| c.rank1_correct), cases.len()),
                    pct(count(&|c| c.top5_correct), cases.len()),
                );
            }
        }
        out
    }

    /// The loop table: one row per kind and input, and one per input for all.
    pub fn loop_table(&self) -> String {
        let mut out = String::from(
            "| kind | input | runs | events | events covered (top 10): turnprint | naive | rank-1 correct: turnprint | naive | precision of top 10: turnprint | naive | events covered (top 50): turnprint | naive |\n\
             |---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n",
        );
        let inputs = [Input::Truth, Input::Walk, Input::Bias, Input::Estimate];
        for (name, kind) in rows() {
            for input in inputs {
                let runs: Vec<&LoopRun> = self
                    .loops
                    .iter()
                    .filter(|r| kind.is_none_or(|k| k == r.kind) && r.input == input)
                    .collect();
                if runs.is_empty() {
                    continue;
                }
                let events: usize = runs.iter().map(|r| r.events).sum();
                let sum = |f: &dyn Fn(&LoopRun) -> usize| runs.iter().map(|r| f(r)).sum::<usize>();
                let _ = writeln!(
                    out,
                    "| {name} | {} | {} | {events} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    input.name(),
                    runs.len(),
                    pct(sum(&|r| r.covered[0]), events),
                    pct(sum(&|r| r.covered[1]), events),
                    pct(sum(&|r| r.rank1_correct[0] as usize), runs.len()),
                    pct(sum(&|r| r.rank1_correct[1] as usize), runs.len()),
                    pct(sum(&|r| r.correct[0]), sum(&|r| r.returned[0])),
                    pct(sum(&|r| r.correct[1]), sum(&|r| r.returned[1])),
                    pct(sum(&|r| r.covered_wide[0]), events),
                    pct(sum(&|r| r.covered_wide[1]), events),
                );
            }
        }
        out
    }

    /// The online detector's table: one row per kind and input that was
    /// replayed, and one per input for all, beside `find_loops`' coverage.
    pub fn online_table(&self) -> String {
        let mut out = String::from(
            "| kind | input | runs | events | events covered: online | batch (top 10) | candidates | correct | share correct |\n\
             |---|---|--:|--:|--:|--:|--:|--:|--:|\n",
        );
        let inputs = [Input::Truth, Input::Walk, Input::Bias, Input::Estimate];
        for (name, kind) in rows() {
            for input in inputs {
                let runs: Vec<(&LoopRun, &OnlineRun)> = self
                    .loops
                    .iter()
                    .filter(|r| kind.is_none_or(|k| k == r.kind) && r.input == input)
                    .filter_map(|r| Some((r, r.online.as_ref()?)))
                    .collect();
                if runs.is_empty() {
                    continue;
                }
                let events: usize = runs.iter().map(|(r, _)| r.events).sum();
                let sum = |f: &dyn Fn(&LoopRun, &OnlineRun) -> usize| {
                    runs.iter().map(|(r, o)| f(r, o)).sum::<usize>()
                };
                let (candidates, correct) = (sum(&|_, o| o.candidates()), sum(&|_, o| o.correct()));
                let _ = writeln!(
                    out,
                    "| {name} | {} | {} | {events} | {} | {} | {candidates} | {correct} | {} |",
                    input.name(),
                    runs.len(),
                    pct(sum(&|_, o| o.covered), events),
                    pct(sum(&|r, _| r.covered[0]), events),
                    pct(correct, candidates),
                );
            }
        }
        out
    }

    /// All tables with the sessions read and the files left out.
    pub fn markdown(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "Seed {}.\n", self.seed);
        if !self.cases.is_empty() || !self.negatives.is_empty() {
            let _ = writeln!(out, "{}", self.merge_table());
            let _ = writeln!(out, "{}", self.merge_by_how());
            let _ = writeln!(out, "Negatives: {}.\n", self.negatives.len());
        }
        if !self.loops.is_empty() {
            let _ = writeln!(out, "{}", self.loop_table());
        }
        if self.loops.iter().any(|r| r.online.is_some()) {
            let _ = writeln!(out, "{}", self.online_table());
        }
        let absent = self
            .skipped
            .iter()
            .filter(|(_, why)| why == "absent")
            .count();
        if absent > 0 {
            let _ = writeln!(
                out,
                "- {absent} files of the catalog are not in the data folder"
            );
        }
        for (file, why) in self.skipped.iter().filter(|(_, why)| why != "absent") {
            let _ = writeln!(out, "- left out: {file}: {why}");
        }
        out
    }
}
