//! The evaluation's results: per-case records, their summaries (rates by
//! source, sequence and kind; ROC AUC; timing) and the Markdown tables.

use std::fmt::Write;
use std::path::Path;

use serde::Serialize;

use super::ambiguity::{BAND_M, BAND_PER_MISFIT, RIVAL_COVER_SHARE};
use super::auc::roc_auc;
use super::baseline::Naive;
use super::checks::median;
use super::data::GpsAlignment;
use super::drift::DriftModel;
use super::loops::LoopRun;
use super::merge::{MergeCase, NegativeCase};
use super::windows::WindowSpec;
use super::{Prepared, Source};

/// Everything one evaluation run measured.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The data directory the sequences were read from.
    pub data_dir: String,
    /// Seed of every random draw.
    pub seed: u64,
    /// Time and space alignment of the KITTI 00 GPS.
    pub gps_alignment: Option<GpsAlignment>,
    /// Ground-truth revisit events per sequence.
    pub events: Vec<(String, usize)>,
    /// Sources without data (skipped), e.g. `"02 mono"`.
    pub missing: Vec<String>,
    /// The merge evaluation (`None`: not run).
    pub merge: Option<MergeReport>,
    /// The loop evaluation (`None`: not run).
    pub loops: Option<LoopsReport>,
}

/// Rates of one group of merge cases.
#[derive(Debug, Clone, Serialize)]
pub struct MergeRow {
    /// The group, e.g. `"all"`, `"source mono"`, `"sequence 00"`, `"B reversed"`.
    pub group: String,
    /// Cases in the group.
    pub cases: usize,
    /// Cases whose rank-1 hypothesis is correct (%; NaN without cases).
    pub rank1_correct_pct: f64,
    /// Cases with a correct hypothesis among the top 5 (%).
    pub top5_correct_pct: f64,
    /// Median over correct rank-1 hypotheses.
    pub median_rot_err_deg: f64,
    /// Median scale error (%) over correct rank-1 hypotheses.
    pub median_scale_err_pct: f64,
}

/// The merge evaluation.
#[derive(Debug, Clone, Serialize)]
pub struct MergeReport {
    /// Lengths (m) the windows are drawn from.
    pub windows: WindowSpec,
    /// Rates of all cases, then per source, sequence, overlap kind, turning of
    /// the common road, shape rival and direction of B.
    pub rows: Vec<MergeRow>,
    /// ROC AUC of rank-1 scores, true pairs against negatives.
    pub auc: f64,
    /// The same over the true pairs without a shape rival.
    pub auc_decidable: f64,
    /// Median wall time (s) of `match_paths` over the cases and negatives.
    pub median_match_s: f64,
    /// Mean wall time (s) of `match_paths` over the cases and negatives.
    pub mean_match_s: f64,
    /// Longest wall time (s) of `match_paths` over the cases and negatives.
    pub max_match_s: f64,
    /// Cases where `match_paths` failed.
    pub errors: usize,
    /// Every positive case that was run.
    pub cases: Vec<MergeCase>,
    /// Every negative pair.
    pub negatives: Vec<NegativeCase>,
    /// Draws skipped because no similarity passes their test.
    pub unattainable: Vec<MergeCase>,
}

/// Figures of one method on one group of loop runs.
#[derive(Debug, Clone, Serialize)]
pub struct LoopFigures {
    /// Runs whose best-ranked loop is correct (%).
    pub rank1_correct_pct: f64,
    /// Ground-truth revisit events touched by a correct top-10 loop, over all
    /// events of the runs (%).
    pub events_covered_pct: f64,
    /// Correct loops among those returned (%; NaN when none was returned).
    pub precision_pct: f64,
    /// Mean wall time per run (s).
    pub mean_s: f64,
}

/// One row of the loop table: a sequence and source (or a total).
#[derive(Debug, Clone, Serialize)]
pub struct LoopRow {
    /// KITTI sequence, or `"all"`.
    pub sequence: String,
    /// Source name (`"gt"`, `"mono"`, ...), or `"all"`.
    pub source: String,
    /// Runs of each method (one per seed).
    pub runs: usize,
    /// Ground-truth revisit events summed over the runs.
    pub events: usize,
    /// Median over runs of the revisit separation (median input steps).
    pub revisit_separation_steps: f64,
    /// Figures of `find_loops`.
    pub turnprint: LoopFigures,
    /// Figures of the naive baseline.
    pub naive: LoopFigures,
}

/// The loop evaluation.
#[derive(Debug, Clone, Serialize)]
pub struct LoopsReport {
    /// Drift model of the `drift` source.
    pub drift: DriftModel,
    /// Settings of the naive baseline.
    pub naive: Naive,
    /// One row per sequence and source, then one per source, then the total.
    pub rows: Vec<LoopRow>,
    /// Every run, both methods.
    pub runs: Vec<LoopRun>,
}

fn pct(n: usize, d: usize) -> f64 {
    if d == 0 {
        f64::NAN
    } else {
        100.0 * n as f64 / d as f64
    }
}

fn merge_row(group: impl Into<String>, cases: &[&MergeCase]) -> MergeRow {
    let n = cases.len();
    let rot: Vec<f64> = cases.iter().filter_map(|c| c.rot_err_deg).collect();
    let scale: Vec<f64> = cases.iter().filter_map(|c| c.scale_err_pct).collect();
    MergeRow {
        group: group.into(),
        cases: n,
        rank1_correct_pct: pct(cases.iter().filter(|c| c.rank1_correct).count(), n),
        top5_correct_pct: pct(cases.iter().filter(|c| c.top5_correct).count(), n),
        median_rot_err_deg: median(&rot),
        median_scale_err_pct: median(&scale),
    }
}

fn loop_figures(runs: &[&LoopRun]) -> LoopFigures {
    let sum = |f: fn(&LoopRun) -> usize| runs.iter().map(|r| f(r)).sum::<usize>();
    LoopFigures {
        rank1_correct_pct: pct(runs.iter().filter(|r| r.rank1_correct).count(), runs.len()),
        events_covered_pct: pct(sum(|r| r.events_covered), sum(|r| r.events)),
        precision_pct: pct(sum(|r| r.correct), sum(|r| r.returned)),
        mean_s: runs.iter().map(|r| r.seconds).sum::<f64>() / runs.len().max(1) as f64,
    }
}

impl Report {
    /// An empty report for the data in `dir`.
    pub fn new(dir: &Path, seed: u64, prepared: &[Prepared]) -> Self {
        Report {
            data_dir: dir.display().to_string(),
            seed,
            gps_alignment: prepared
                .iter()
                .find_map(|p| p.seq.gps.as_ref().map(|g| g.1.clone())),
            missing: prepared
                .iter()
                .flat_map(|p| {
                    let mut m = Vec::new();
                    if !p.has(Source::Mono) {
                        m.push(format!("{} mono", p.seq.name));
                    }
                    if p.seq.name == "00" && !p.has(Source::Gps) {
                        m.push("00 gps".to_string());
                    }
                    m
                })
                .collect(),
            events: prepared
                .iter()
                .map(|p| (p.seq.name.clone(), p.events.len()))
                .collect(),
            merge: None,
            loops: None,
        }
    }

    /// Summarises the merge cases.
    pub fn set_merge(
        &mut self,
        cases: Vec<MergeCase>,
        negatives: Vec<NegativeCase>,
        unattainable: Vec<MergeCase>,
        windows: WindowSpec,
    ) {
        let all: Vec<&MergeCase> = cases.iter().collect();
        let mut rows = vec![merge_row("all", &all)];
        let mut sources: Vec<Source> = all.iter().map(|c| c.source).collect();
        sources.sort();
        sources.dedup();
        for s in sources {
            let g: Vec<_> = all.iter().copied().filter(|c| c.source == s).collect();
            rows.push(merge_row(format!("source {}", s.name()), &g));
        }
        let mut seqs: Vec<&str> = all.iter().map(|c| c.sequence.as_str()).collect();
        seqs.sort();
        seqs.dedup();
        for s in seqs {
            let g: Vec<_> = all.iter().copied().filter(|c| c.sequence == s).collect();
            rows.push(merge_row(format!("sequence {s}"), &g));
        }
        for (name, pick) in [
            (
                "time overlap",
                &(|c: &MergeCase| c.kind == "time") as &dyn Fn(&MergeCase) -> bool,
            ),
            ("revisit overlap", &|c: &MergeCase| c.kind == "revisit"),
            ("common road turning < 90°", &|c: &MergeCase| {
                c.overlap_turning_deg < 90.0
            }),
            ("common road turning 90-180°", &|c: &MergeCase| {
                (90.0..180.0).contains(&c.overlap_turning_deg)
            }),
            ("common road turning >= 180°", &|c: &MergeCase| {
                c.overlap_turning_deg >= 180.0
            }),
            ("no shape rival", &|c: &MergeCase| !c.shape_rival),
            ("shape rival (ambiguous by shape)", &|c: &MergeCase| {
                c.shape_rival
            }),
            ("B forward", &|c: &MergeCase| !c.reversed),
            ("B reversed", &|c: &MergeCase| c.reversed),
        ] {
            let g: Vec<_> = all.iter().copied().filter(|c| pick(c)).collect();
            rows.push(merge_row(name, &g));
        }
        let pos: Vec<f64> = cases.iter().map(|c| c.rank1_score).collect();
        let decidable: Vec<f64> = cases
            .iter()
            .filter(|c| !c.shape_rival)
            .map(|c| c.rank1_score)
            .collect();
        let neg: Vec<f64> = negatives.iter().map(|n| n.rank1_score).collect();
        let times: Vec<f64> = cases
            .iter()
            .map(|c| c.seconds)
            .chain(negatives.iter().map(|n| n.seconds))
            .collect();
        self.merge = Some(MergeReport {
            windows,
            rows,
            auc: roc_auc(&pos, &neg),
            auc_decidable: roc_auc(&decidable, &neg),
            median_match_s: median(&times),
            mean_match_s: times.iter().sum::<f64>() / times.len().max(1) as f64,
            max_match_s: times.iter().copied().fold(0.0, f64::max),
            errors: cases.iter().filter(|c| c.error.is_some()).count(),
            cases,
            negatives,
            unattainable,
        });
    }

    /// Summarises the loop runs per sequence and source, then per source.
    pub fn set_loops(&mut self, runs: Vec<LoopRun>, drift: DriftModel, naive: Naive) {
        let mut rows = Vec::new();
        let mut keys: Vec<(String, Source)> = runs
            .iter()
            .map(|r| (r.sequence.clone(), r.source))
            .collect();
        keys.dedup();
        let row = |seq: &str, source: &str, pick: &dyn Fn(&LoopRun) -> bool| {
            let tp: Vec<&LoopRun> = runs
                .iter()
                .filter(|r| r.method == "turnprint" && pick(r))
                .collect();
            let nv: Vec<&LoopRun> = runs
                .iter()
                .filter(|r| r.method == "naive" && pick(r))
                .collect();
            LoopRow {
                sequence: seq.to_string(),
                source: source.to_string(),
                runs: tp.len(),
                events: tp.iter().map(|r| r.events).sum(),
                revisit_separation_steps: median(
                    &tp.iter()
                        .map(|r| r.revisit_separation_steps)
                        .collect::<Vec<_>>(),
                ),
                turnprint: loop_figures(&tp),
                naive: loop_figures(&nv),
            }
        };
        for (seq, source) in &keys {
            rows.push(row(seq, source.name(), &|r| {
                &r.sequence == seq && r.source == *source
            }));
        }
        let mut sources: Vec<Source> = runs.iter().map(|r| r.source).collect();
        sources.sort();
        sources.dedup();
        for source in sources {
            rows.push(row("all", source.name(), &|r| r.source == source));
        }
        rows.push(row("all", "all", &|_| true));
        self.loops = Some(LoopsReport {
            drift,
            naive,
            rows,
            runs,
        });
    }

    /// The tables in Markdown.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "Data: `{}`, seed {}.\n", self.data_dir, self.seed);
        if !self.missing.is_empty() {
            let _ = writeln!(s, "Missing data, skipped: {}.\n", self.missing.join(", "));
        }
        if let Some(m) = &self.merge {
            self.merge_markdown(m, &mut s);
        }
        if let Some(l) = &self.loops {
            self.loops_markdown(l, &mut s);
        }
        s
    }

    fn merge_markdown(&self, m: &MergeReport, s: &mut String) {
        let w = &m.windows;
        let rev = m.cases.iter().filter(|c| c.reversed).count();
        let _ = writeln!(s, "## Merging real paths\n");
        let _ = writeln!(
            s,
            "{} cases ({} with B reversed), {} negatives. A: ground-truth window of {:.0}-{:.0} m; \
             B: common road {:.0}-{:.0} m plus {:.0}-{:.0} m beyond A on one or both sides, under a random \
             similarity (scale log-uniform 0.01..100, uniform rotation). Correct: median error of B's \
             common-road poses <= max(2 % of common length, 3 m) and both ranges touch the common road.\n",
            m.cases.len(),
            rev,
            m.negatives.len(),
            w.a_len.0,
            w.a_len.1,
            w.overlap.0,
            w.overlap.1,
            w.extra.0,
            w.extra.1
        );
        if let Some(g) = &self.gps_alignment {
            let _ = writeln!(
                s,
                "GPS of KITTI 00: t_kitti = t_gps - {:.3} s; similarity scale {:.4}; RMSE {:.2} m over {} of {} rows.\n",
                g.offset_s, g.scale, g.rmse_m, g.rows_used, g.rows
            );
        }
        let _ = writeln!(
            s,
            "| group | cases | rank-1 correct | top-5 correct | median rot. error of correct rank-1 (deg) | median scale error of correct rank-1 (%) |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|");
        for r in &m.rows {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} |",
                r.group,
                r.cases,
                fmt_pct(r.rank1_correct_pct),
                fmt_pct(r.top5_correct_pct),
                fmt_num(r.median_rot_err_deg, 2),
                fmt_num(r.median_scale_err_pct, 2)
            );
        }
        let _ = writeln!(
            s,
            "\nROC AUC of rank-1 scores, {} true pairs vs {} negatives (score 0 without a hypothesis): **{}** (target >= 0.95).\n",
            m.cases.len(),
            m.negatives.len(),
            fmt_num(m.auc, 3)
        );
        let rivals = m.cases.iter().filter(|c| c.shape_rival).count();
        let _ = writeln!(
            s,
            "Shape rival (`src/eval/ambiguity.rs`): a slide along the common road or a scaling about \
             one of its ends that fails the test yet lays at least {:.0} % of the road length and of the \
             turning of B that the truth lays within a band of A ({} times the truth's misfit, {}-{} m). \
             No method that sees only the two paths \
             can tell such a case's truth from its rival. {} of {} cases have one; over the other {}, \
             ROC AUC against the negatives: **{}**.\n",
            100.0 * RIVAL_COVER_SHARE,
            BAND_PER_MISFIT,
            BAND_M.0,
            BAND_M.1,
            rivals,
            m.cases.len(),
            m.cases.len() - rivals,
            fmt_num(m.auc_decidable, 3)
        );
        let _ = writeln!(
            s,
            "Skipped draws: {} where no single similarity passes the test (the source itself bends more than \
             the tolerance over the common road, e.g. mono drift between two passes: {}).\n",
            m.unattainable.len(),
            m.unattainable
                .iter()
                .map(|c| format!("{} {} frames {:?}", c.sequence, c.source.name(), c.b_frames))
                .collect::<Vec<_>>()
                .join("; ")
        );
        let wrong: Vec<&MergeCase> = m.cases.iter().filter(|c| !c.rank1_correct).collect();
        let _ = writeln!(
            s,
            "Rank-1 failures: {} without a hypothesis, {} with a range off the common road, \
             {} on the common road with the similarity off by more than the tolerance.\n",
            wrong
                .iter()
                .filter(|c| c.rank1_ranges_hit.is_none())
                .count(),
            wrong
                .iter()
                .filter(|c| c.rank1_ranges_hit == Some(false))
                .count(),
            wrong
                .iter()
                .filter(|c| c.rank1_ranges_hit == Some(true))
                .count(),
        );
        let _ = writeln!(
            s,
            "Time per match: median {:.1} ms, mean {:.1} ms, max {:.1} ms. `match_paths` errors: {}.\n",
            1e3 * m.median_match_s,
            1e3 * m.mean_match_s,
            1e3 * m.max_match_s,
            m.errors
        );
    }

    fn loops_markdown(&self, l: &LoopsReport, s: &mut String) {
        let d = &l.drift;
        let _ = writeln!(s, "## Loops on real paths\n");
        let events: Vec<String> = self
            .events
            .iter()
            .map(|(n, e)| format!("{n}: {e}"))
            .collect();
        let _ = writeln!(
            s,
            "Revisit: pose within 8 m of a ground-truth pose >= 300 frames earlier; event: run of revisits \
             (gaps <= 5 frames) spanning >= 40 m. Events per sequence: {}. Loop correct: median distance \
             from its query poses to the nearest match poses <= 10 m (ground truth). Drift input: heading \
             random walk {} deg/sqrt(m) and log-scale random walk {} /sqrt(m), knots every {} m, integrated \
             over the relative motions. Naive baseline: nearest pose >= {} frames earlier in the input's \
             frame within {} median steps, hits grouped (gaps <= {}, match jumps <= {}), ranked by mean \
             distance. Every input is under a random similarity. Revisit separation: median, over ground-truth \
             revisits, of the input-frame distance to the revisited pose in median input steps (what the naive \
             search sees; its threshold is {}).\n",
            events.join(", "),
            d.heading_deg_per_sqrt_len,
            d.log_scale_per_sqrt_len,
            d.knot_spacing,
            l.naive.min_gap,
            l.naive.threshold_steps,
            l.naive.max_gap,
            l.naive.max_match_jump,
            l.naive.threshold_steps
        );
        let _ = writeln!(
            s,
            "| sequence | source | runs | events | revisit separation (steps) | rank-1 correct: turnprint | naive | events covered (top 10): turnprint | naive | precision of top 10: turnprint | naive | time per run: turnprint (s) |"
        );
        let _ = writeln!(
            s,
            "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        );
        for r in &l.rows {
            let bold = if r.source == "drift" { "**" } else { "" };
            let _ = writeln!(
                s,
                "| {} | {b}{}{b} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} |",
                r.sequence,
                r.source,
                r.runs,
                r.events,
                fmt_num(r.revisit_separation_steps, 1),
                fmt_pct(r.turnprint.rank1_correct_pct),
                fmt_pct(r.naive.rank1_correct_pct),
                fmt_pct(r.turnprint.events_covered_pct),
                fmt_pct(r.naive.events_covered_pct),
                fmt_pct(r.turnprint.precision_pct),
                fmt_pct(r.naive.precision_pct),
                r.turnprint.mean_s,
                b = bold
            );
        }
        let _ = writeln!(
            s,
            "\nTargets: rank-1 correct on >= 90 % of runs, >= 90 % of events covered. Precision is `-` when nothing was returned. \
             `find_loops` errors: {}.\n",
            l.runs.iter().filter(|r| r.error.is_some()).count()
        );
    }
}

fn fmt_pct(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.1} %")
    } else {
        "-".to_string()
    }
}

fn fmt_num(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{v:.digits$}")
    } else {
        "-".to_string()
    }
}
