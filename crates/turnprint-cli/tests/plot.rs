//! Merge and loops figures: SVG and PNG files of hypotheses on real KITTI
//! 00 poses.

use std::path::Path;

use nalgebra::{Matrix3, Vector3};
use turnprint::io::{read_trajectory, Format};
use turnprint::{Error, Hypothesis};
use turnprint_cli::plot::{plot_loops, plot_merge};

/// Two halves of KITTI 00 and the hypothesis that joins them.
type Halves = (Vec<Vector3<f64>>, Vec<Vector3<f64>>, Hypothesis);

/// A: KITTI 00 poses 0-3000; B: poses 1500-4540 shifted by 17 m,
/// so B's first 1501 poses are A's poses 1500-3000 (B is already in A's
/// frame: identity similarity). `None` when the data is absent.
fn kitti00_halves() -> Option<Halves> {
    let positions = kitti00()?;
    let a = positions[..=3000].to_vec();
    // A residual of some metres, as a drifting estimate has, so that the
    // correspondence lines have length.
    let residual = Vector3::new(12.0, 0.0, -12.0);
    let b: Vec<Vector3<f64>> = positions[1500..].iter().map(|p| p + residual).collect();
    let hypothesis = Hypothesis {
        rank: 1,
        score: 0.9,
        zncc: 0.95,
        reversed: false,
        a_range: [1500, 3000],
        b_range: [0, 1500],
        scale: 1.0,
        rotation: Matrix3::identity(),
        translation: Vector3::zeros(),
        rmse: residual.norm(),
        turning: 3.0,
        length: 1200.0,
        length_ratio: 1.0,
        correspondences: (0..=1500).map(|k| (1500 + k, k)).collect(),
    };
    Some((a, b, hypothesis))
}

/// KITTI 00 ground-truth positions from the shared data (`None`, after a
/// line saying so, when it is absent).
fn kitti00() -> Option<Vec<Vector3<f64>>> {
    let path = turnprint_eval::data::require("kitti_gt/00.txt")?;
    Some(read_trajectory(&path, Format::Kitti).unwrap().positions())
}

#[test]
fn svg_figure_is_well_formed_xml_with_the_title() {
    let Some((a, b, h)) = kitti00_halves() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("merge.svg");
    plot_merge(&out, &a, &b, &h).unwrap();
    let svg = std::fs::read_to_string(&out).unwrap();
    assert!(svg.contains("<svg"));
    assert!(svg.contains("score 0.900"), "title missing");
    let (elements, texts) = svg_contents(&svg);
    // Two paths, two common parts, 59 correspondence lines, axes, legend.
    assert!(elements > 60, "{elements} elements");
    // KITTI camera poses lie in the x/z plane: drawn with those axes.
    assert!(
        texts.iter().any(|t| t == "x") && texts.iter().any(|t| t == "z"),
        "{texts:?}"
    );
}

#[test]
fn png_figure_has_the_png_signature_and_size() {
    let Some((a, b, h)) = kitti00_halves() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("merge.png");
    plot_merge(&out, &a, &b, &h).unwrap();
    let bytes = std::fs::read(&out).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let width = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let height = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    assert!(width >= 800 && height >= 800, "{width}x{height}");
    assert!(bytes.len() > 20_000, "{} bytes", bytes.len());
    if let Ok(keep) = std::env::var("TURNPRINT_KEEP_FIGURE") {
        std::fs::copy(&out, keep).unwrap();
    }
}

#[test]
fn other_extensions_and_empty_paths_are_input_errors() {
    let Some((a, b, h)) = kitti00_halves() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let err = plot_merge(&dir.path().join("merge.pdf"), &a, &b, &h).unwrap_err();
    assert!(matches!(err, Error::Input { .. }), "{err:?}");
    assert!(err.to_string().contains(".svg or .png"), "{err}");
    let err = plot_merge(&dir.path().join("m.svg"), &[], &b, &h).unwrap_err();
    assert!(matches!(err, Error::Input { .. }), "{err:?}");
    let mut bad = a.clone();
    bad[3].x = f64::NAN;
    let err = plot_merge(&dir.path().join("m.png"), &bad, &b, &h).unwrap_err();
    assert!(err.to_string().contains("not finite"), "{err}");
    let err = plot_merge(Path::new("/nonexistent-dir/m.png"), &a, &b, &h).unwrap_err();
    assert!(matches!(err, Error::Io { .. }), "{err:?}");
}

/// The number of elements and every text node of an SVG file (and a check
/// that it is XML).
fn svg_contents(svg: &str) -> (usize, Vec<String>) {
    let mut reader = quick_xml::Reader::from_str(svg);
    let (mut elements, mut texts) = (0, Vec::new());
    loop {
        match reader.read_event() {
            Ok(quick_xml::events::Event::Eof) => break,
            Ok(quick_xml::events::Event::Start(_) | quick_xml::events::Event::Empty(_)) => {
                elements += 1
            }
            Ok(quick_xml::events::Event::Text(t)) => {
                texts.push(t.xml10_content().trim().to_string())
            }
            Ok(_) => {}
            Err(e) => panic!("SVG is not XML: {e}"),
        }
    }
    (elements, texts)
}

#[test]
fn loops_figure_names_every_loop_and_its_score() {
    let (Some(positions), Some((_, _, first))) = (kitti00(), kitti00_halves()) else {
        return;
    };
    // Twelve loops: the colours repeat past the tenth, and every one is
    // named in the legend.
    let loops: Vec<Hypothesis> = (0..12)
        .map(|i| Hypothesis {
            rank: i + 1,
            score: 0.9 - 0.05 * i as f64,
            a_range: [3000 + 100 * i, 3100 + 100 * i],
            b_range: [100 * i, 100 + 100 * i],
            correspondences: (0..=100)
                .map(|k| (3000 + 100 * i + k, 100 * i + k))
                .collect(),
            ..first.clone()
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("loops.svg");
    plot_loops(&out, &positions, &loops).unwrap();
    let (_, texts) = svg_contents(&std::fs::read_to_string(&out).unwrap());
    for i in 1..=12 {
        assert!(texts.contains(&format!("#{i}")), "#{i} missing: {texts:?}");
    }
    assert!(
        texts
            .iter()
            .any(|t| t.contains("0.90") && t.contains("0.35")),
        "scores missing: {texts:?}"
    );
    assert!(texts
        .iter()
        .any(|t| t.starts_with("12 loops of 4541 poses")));
    // No loop at all is a figure of the path alone; no path is an error.
    let out = dir.path().join("none.png");
    plot_loops(&out, &positions, &[]).unwrap();
    assert_eq!(&std::fs::read(&out).unwrap()[..8], b"\x89PNG\r\n\x1a\n");
    let err = plot_loops(&dir.path().join("e.svg"), &[], &loops).unwrap_err();
    assert!(err.to_string().contains("no poses"), "{err}");
}

/// A merge of many paths: every merged path named in the legend until it
/// reaches the figure's edge, the rest cut short with "...", the paths not
/// merged named in the title; an empty first path is an input error.
#[test]
fn placement_figure_names_the_merged_paths_and_those_left_out() {
    use turnprint_cli::plot::plot_placement;
    // Forty circles of a generated fixture, every fifth not merged.
    let circle = |k: usize| -> Vec<Vector3<f64>> {
        (0..100)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 100.0;
                Vector3::new(k as f64 + a.cos(), a.sin(), 0.0)
            })
            .collect()
    };
    let paths: Vec<Option<Vec<Vector3<f64>>>> =
        (0..40).map(|k| (k % 5 != 4).then(|| circle(k))).collect();
    let overlaps = [(0, 1, [0, 30], [10, 40])];
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("many.svg");
    plot_placement(&out, &paths, &overlaps).unwrap();
    let (_, texts) = svg_contents(&std::fs::read_to_string(&out).unwrap());
    assert!(
        texts.iter().any(|t| t.starts_with("32 of 40 paths placed")),
        "{texts:?}"
    );
    assert!(
        texts.iter().any(|t| t.starts_with("not merged: P5, P10")),
        "{texts:?}"
    );
    assert!(texts.iter().any(|t| t == "P1") && texts.iter().any(|t| t == "P2"));
    assert!(
        texts.iter().any(|t| t == "..."),
        "legend not cut at the edge"
    );
    assert!(!texts.iter().any(|t| t == "P39"), "legend past the edge");
    let mut none_first = paths.clone();
    none_first[0] = Some(Vec::new());
    let err = plot_placement(&dir.path().join("m.svg"), &none_first, &[]).unwrap_err();
    assert!(matches!(err, Error::Input { .. }), "{err:?}");
}
