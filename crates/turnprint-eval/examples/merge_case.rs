//! Replays one merge case of the evaluation and shows why it went the way
//! it did: the true common road, how close the best single similarity
//! gets, whether a failing placement is as well supported by shape
//! (`turnprint_eval::ambiguity`), and each hypothesis with its verdict.
//! Take the windows from a failure in `evaluate --json` (`sequence`,
//! `source`, `a_frames`, `b_frames`, `reversed`).
//!
//! Usage: `cargo run --release --example merge_case -- SEQ SOURCE A0 A1 B0
//! B1 [reversed] [TOP]` (`SOURCE`: gt, mono or gps; `TOP` hypotheses,
//! default 10; the data in `$DATA`, default `../shared/data`).
//!
//! B's random similarity differs from the evaluation's draw: the matcher
//! is invariant to it, so the case is the same.

use std::path::PathBuf;

use rand::SeedableRng;
use turnprint_eval::{data::load_sequence, merge::run_case, Prepared, Source};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: merge_case SEQ gt|mono|gps A0 A1 B0 B1 [reversed] [TOP]";
    if args.len() < 6 {
        return Err(usage.into());
    }
    let source = match args[1].as_str() {
        "gt" => Source::Gt,
        "mono" => Source::Mono,
        "gps" => Source::Gps,
        _ => return Err(usage.into()),
    };
    let frame = |i: usize| args[i].parse::<usize>();
    let windows = [[frame(2)?, frame(3)?], [frame(4)?, frame(5)?]];
    let reversed = args.get(6).is_some_and(|a| a == "reversed");
    let top = match args.last().and_then(|a| a.parse().ok()) {
        Some(top) if args.len() > 6 => top,
        _ => 10,
    };
    let data = PathBuf::from(std::env::var("DATA").unwrap_or_else(|_| "../shared/data".into()));
    let p = Prepared::new(load_sequence(&data, &args[0])?);
    if !p.has(source) {
        return Err(format!("no {} data for {}", source.name(), args[0]).into());
    }
    let mut rng = rand::rngs::StdRng::seed_from_u64(1);
    let run = run_case(&mut rng, &p, source, reversed, windows, 0.0, top)
        .ok_or("B is too short or shares no road with A")?;
    let t = &run.truth;
    println!(
        "common road: A {}..{} of {} poses, B {}..{} of {} ({:.0} m, {:.0}° of turning), B {}",
        t.a[0],
        t.a[t.a.len() - 1],
        run.a_poses,
        t.b[0],
        t.b[t.b.len() - 1],
        run.b_input.len(),
        t.length,
        run.turning_deg,
        if run.reversed { "reversed" } else { "forward" },
    );
    match &run.oracle {
        Some((o, v)) => println!(
            "best single similarity: median error {:.2} m (tolerance {:.2} m), scale {:.4}",
            v.median_error, v.tolerance, o.scale
        ),
        None => println!("best single similarity: none"),
    }
    if let Some(a) = &run.ambiguity {
        let t = a.truth;
        print!(
            "shape support of the truth: {:.0} m and {:.0}° of B within {:.1} m of A; ",
            t.length_m, t.turning_deg, a.band_m
        );
        match a.best_rival {
            Some(r) => println!(
                "best failing rival: {} {:+.2} tolerances, {:.0} m and {:.0}°, error {:.1} m{}",
                r.kind,
                r.amount,
                r.support.length_m,
                r.support.turning_deg,
                r.median_error,
                if a.has_rival() {
                    " (ambiguous by shape)"
                } else {
                    ""
                }
            ),
            None => println!("no failing rival"),
        }
    }
    if let Some(e) = &run.error {
        println!("match_paths failed: {e}");
    }
    println!(
        "rank score  zncc  rev  a range      b range      scale/true rmse   turn  error   verdict"
    );
    let true_scale = run.oracle.as_ref().map_or(f64::NAN, |(o, _)| o.scale);
    for (h, v) in &run.hypotheses {
        println!(
            "{:>4} {:.3} {:.3} {:>4} {:>5}..{:<5} {:>5}..{:<5} {:>10.4} {:>5.2} {:>5.0} {:>7.2} {}",
            h.rank,
            h.score,
            h.zncc,
            if h.reversed { "yes" } else { "no" },
            h.a_range[0],
            h.a_range[1],
            h.b_range[0],
            h.b_range[1],
            h.scale / true_scale,
            h.rmse,
            h.turning.to_degrees(),
            v.median_error,
            match (v.correct, v.ranges_hit) {
                (true, _) => "correct",
                (false, true) => "off the similarity",
                (false, false) => "off the road",
            }
        );
    }
    Ok(())
}
