//! `turnprint stream A --json` (cli.md): JSON Lines, candidates with the
//! fields of a `loops` entry plus `event`, `at_pose` and `id`, then one
//! summary line; bad input is an error naming the file.

use turnprint::io::Format;
use turnprint::online::OnlineConfig;
use turnprint_cli::stream::stream;

#[test]
fn stream_writes_candidates_then_a_summary() {
    let Some(kitti00) = turnprint_eval::data::require("kitti_gt/00.txt") else {
        return;
    };
    let mut out = Vec::new();
    let summary = stream(
        &kitti00,
        Format::Auto,
        &OnlineConfig::default(),
        None,
        &mut out,
    )
    .unwrap();
    let lines: Vec<serde_json::Value> = String::from_utf8(out)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).expect("each line is JSON"))
        .collect();
    let (last, candidates) = lines.split_last().unwrap();
    assert_eq!(last["event"], "summary");
    assert_eq!(last["poses"], 4541);
    assert_eq!(
        last["candidates"].as_u64().unwrap() as usize,
        candidates.len()
    );
    assert_eq!(summary.worker.candidates as usize, candidates.len());
    assert!(!candidates.is_empty());
    for c in candidates {
        assert_eq!(c["event"], "candidate");
        for key in [
            "at_pose",
            "id",
            "rank",
            "score",
            "zncc",
            "reversed",
            "query_range",
            "match_range",
            "scale",
            "rotation",
            "translation",
            "rmse",
        ] {
            assert!(c.get(key).is_some(), "missing {key} in {c}");
        }
        let q = c["query_range"].as_array().unwrap();
        let m = c["match_range"].as_array().unwrap();
        // The query is the later part, produced no later than its arrival.
        assert!(m[0].as_u64() <= q[0].as_u64());
        assert!(q[1].as_u64().unwrap() <= c["at_pose"].as_u64().unwrap());
        let s = c["score"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&s));
    }
}

#[test]
fn stream_names_the_file_on_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.txt");
    std::fs::write(&bad, "0 0 0\n1 1 nan\n").unwrap();
    let err = stream(
        &bad,
        Format::Xyz,
        &OnlineConfig::default(),
        None,
        &mut Vec::new(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("bad.txt"), "{err}");
    let short = dir.path().join("short.txt");
    std::fs::write(&short, "0 0 0\n1 1 0\n").unwrap();
    let err = stream(
        &short,
        Format::Xyz,
        &OnlineConfig::default(),
        None,
        &mut Vec::new(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("short.txt"), "{err}");
}
