//! Figures of a merge (like Fig. 4/5 of the paper): path A and path B,
//! already mapped into A's frame, drawn in one top view, with the common
//! part and the correspondences of the hypothesis; and of the loops of one
//! path: the path, each loop's query and match parts in its own colour, and
//! its correspondences; and of a merge of many paths: each placed path in
//! its own colour in the first one's frame, with the overlaps that placed
//! them.
//!
//! The view is an orthographic projection onto A's best-fit plane. The plane
//! is the span of the two largest principal axes of A's positions
//! (eigenvectors of their 3x3 covariance). When that plane lies within
//! about 25 degrees of a coordinate plane of A's frame (|n_k| > 0.9 for the
//! plane normal n) the two coordinate axes spanning it are used instead, so
//! a path planar in x/y is drawn with x to the right and y up, and a KITTI
//! camera path (planar in x/z) with x to the right and z up. Both axes have
//! the same scale. The figure is SVG or PNG, chosen by the file extension.

use std::path::Path;
use std::sync::OnceLock;

use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use plotters::coord::Shift;
use plotters::prelude::*;

use turnprint::{Error, Hypothesis, Result};

/// DejaVu Sans (see assets/DejaVuSans-LICENSE.md): the bitmap backend has
/// no system fonts, so text needs a font compiled in.
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Most correspondence lines drawn; more would hide the paths.
const MAX_CORRESPONDENCE_LINES: usize = 60;

/// Plotting square side in pixels.
const PLOT_SIDE: u32 = 800;
const MARGIN: u32 = 15;
const X_LABELS: u32 = 45;
const Y_LABELS: u32 = 75;
const TITLE: u32 = 90;

/// Colours of Fig. 4/5: A red, B green, common parts magenta (A) and blue (B).
/// A's common part is drawn wider than B's, under it, so both stay visible
/// where they coincide.
const A_COLOUR: RGBColor = RGBColor(220, 30, 30);
const B_COLOUR: RGBColor = RGBColor(0, 150, 0);
const A_COMMON: RGBColor = RGBColor(200, 0, 200);
const B_COMMON: RGBColor = RGBColor(0, 60, 255);

/// Draws A, B mapped into A's frame (`b_in_a`), the common part and the
/// correspondences of `hypothesis` to `out` (`.svg` or `.png`).
pub fn plot_merge(
    out: &Path,
    a: &[Vector3<f64>],
    b_in_a: &[Vector3<f64>],
    hypothesis: &Hypothesis,
) -> Result<()> {
    render(
        out,
        &Figure::Merge {
            a,
            b_in_a,
            h: hypothesis,
        },
    )
}

/// Draws `path` and its `loops` (each query part, match part and
/// correspondences in the loop's own colour, best first) to `out` (`.svg`
/// or `.png`), in the path's own frame.
pub fn plot_loops(out: &Path, path: &[Vector3<f64>], loops: &[Hypothesis]) -> Result<()> {
    render(out, &Figure::Loops { path, loops })
}

/// One loop of a correction figure: its query and match ranges and whether
/// the pose graph kept it.
pub type LoopMark = ([usize; 2], [usize; 2], bool);

/// Draws the path `before` and `after` drift correction in one view (the
/// corrected path's), with a line between the two parts of each loop on the
/// corrected path: green if kept, red if rejected.
pub fn plot_correction(
    out: &Path,
    before: &[Vector3<f64>],
    after: &[Vector3<f64>],
    loops: &[LoopMark],
) -> Result<()> {
    render(
        out,
        &Figure::Correction {
            before,
            after,
            loops,
        },
    )
}

/// One path of a placement figure: its positions in the first path's
/// frame, or `None` where it was not merged.
pub type Placed = Option<Vec<Vector3<f64>>>;

/// One overlap of a placement figure: the two paths' indices and the pose
/// ranges they share.
pub type OverlapMark = (usize, usize, [usize; 2], [usize; 2]);

/// Draws every merged path of a many-path merge in the first path's frame,
/// each in its own colour (`P1`, `P2`, ... in input order), with the common
/// parts of the overlaps that placed them drawn wide.
pub fn plot_placement(out: &Path, paths: &[Placed], overlaps: &[OverlapMark]) -> Result<()> {
    render(out, &Figure::Placement { paths, overlaps })
}

/// What a figure shows.
enum Figure<'a> {
    /// Many paths placed in the first one's frame, and the overlaps used.
    Placement {
        paths: &'a [Placed],
        overlaps: &'a [OverlapMark],
    },
    /// A path before and after drift correction, and its loops.
    Correction {
        before: &'a [Vector3<f64>],
        after: &'a [Vector3<f64>],
        loops: &'a [LoopMark],
    },
    /// A, B in A's frame, and the hypothesis that put it there.
    Merge {
        a: &'a [Vector3<f64>],
        b_in_a: &'a [Vector3<f64>],
        h: &'a Hypothesis,
    },
    /// One path and its loops.
    Loops {
        path: &'a [Vector3<f64>],
        loops: &'a [Hypothesis],
    },
}

impl Figure<'_> {
    /// The path that sets the view and must not be empty, and its name.
    fn reference(&self) -> (&[Vector3<f64>], &'static str) {
        match self {
            Figure::Merge { a, .. } => (a, "path A"),
            Figure::Placement { paths, .. } => (
                paths.first().and_then(|p| p.as_deref()).unwrap_or(&[]),
                "the first path",
            ),
            Figure::Loops { path, .. } => (path, "the path"),
            Figure::Correction { after, .. } => (after, "the corrected path"),
        }
    }

    /// Every point drawn.
    fn points(&self) -> Box<dyn Iterator<Item = &Vector3<f64>> + '_> {
        let (first, second): (&[Vector3<f64>], &[Vector3<f64>]) = match self {
            Figure::Merge { a, b_in_a, .. } => (a, b_in_a),
            Figure::Loops { path, .. } => (path, &[]),
            Figure::Correction { before, after, .. } => (after, before),
            Figure::Placement { paths, .. } => {
                return Box::new(paths.iter().flatten().flatten());
            }
        };
        Box::new(first.iter().chain(second))
    }
}

/// Checks the figure and writes it with the backend its extension names.
fn render(out: &Path, figure: &Figure) -> Result<()> {
    let name = out.display().to_string();
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("svg") | Some("png")) {
        return Err(Error::input(
            name,
            "figure file name must end in .svg or .png",
        ));
    }
    let (reference, what) = figure.reference();
    if reference.is_empty() {
        return Err(Error::input(name, format!("{what} has no poses to plot")));
    }
    if figure.points().any(|p| !p.iter().all(|v| v.is_finite())) {
        return Err(Error::input(name, "a position to plot is not finite"));
    }
    register_font().map_err(|m| Error::input(&name, m))?;
    let view = View::of(reference);
    let size = (
        PLOT_SIDE + 2 * MARGIN + Y_LABELS,
        PLOT_SIDE + 2 * MARGIN + X_LABELS + TITLE,
    );
    let drawn = if ext.as_deref() == Some("svg") {
        draw(
            SVGBackend::new(out, size).into_drawing_area(),
            &view,
            figure,
        )
    } else {
        draw(
            BitMapBackend::new(out, size).into_drawing_area(),
            &view,
            figure,
        )
    };
    drawn.map_err(|message| Error::Io {
        path: out.to_path_buf(),
        source: std::io::Error::other(message),
    })
}

/// Registers the embedded font as plotters' `sans-serif`, once.
fn register_font() -> std::result::Result<(), String> {
    static REGISTERED: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
                .map_err(|_| "the embedded font cannot be read".to_string())
        })
        .clone()
}

/// The projection of the figure: two orthonormal axes of A's plane.
struct View {
    axes: [Vector3<f64>; 2],
    names: [&'static str; 2],
}

impl View {
    /// The view onto A's best-fit plane (see the module doc).
    fn of(a: &[Vector3<f64>]) -> View {
        let n = a.len() as f64;
        let mean = a.iter().sum::<Vector3<f64>>() / n;
        let covariance = a
            .iter()
            .map(|p| (p - mean) * (p - mean).transpose())
            .sum::<Matrix3<f64>>()
            / n;
        let eigen = SymmetricEigen::new(covariance);
        let mut order = [0, 1, 2];
        order.sort_by(|&i, &j| eigen.eigenvalues[j].total_cmp(&eigen.eigenvalues[i]));
        let normal = eigen.eigenvectors.column(order[2]).into_owned();
        let (k, largest) =
            normal
                .iter()
                .map(|v| v.abs())
                .enumerate()
                .fold(
                    (2, 0.0),
                    |best, (i, v)| if v > best.1 { (i, v) } else { best },
                );
        // Degenerate A (a point or a line) has no plane: x/y then.
        let planar = eigen.eigenvalues[order[1]] > 1e-12 * eigen.eigenvalues[order[0]].max(1e-300);
        if largest > 0.9 || !planar {
            let (i, j, names) = match k {
                0 => (1, 2, ["y", "z"]),
                1 => (0, 2, ["x", "z"]),
                _ => (0, 1, ["x", "y"]),
            };
            let (i, j, names) = if planar {
                (i, j, names)
            } else {
                (0, 1, ["x", "y"])
            };
            return View {
                axes: [Vector3::ith(i, 1.0), Vector3::ith(j, 1.0)],
                names,
            };
        }
        let first = eigen.eigenvectors.column(order[0]).into_owned();
        View {
            axes: [first, normal.cross(&first)],
            names: ["plane axis 1", "plane axis 2"],
        }
    }

    /// The 2D figure coordinates of a point.
    fn project(&self, p: &Vector3<f64>) -> (f64, f64) {
        (self.axes[0].dot(p), self.axes[1].dot(p))
    }
}

/// Square ranges (same units per pixel on both axes) holding every point.
fn equal_ranges(points: &[(f64, f64)]) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in points {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    let span = (x1 - x0).max(y1 - y0);
    // A single point still needs a non-empty range.
    let half = if span > 0.0 { 0.53 * span } else { 1.0 };
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    ((cx - half)..(cx + half), (cy - half)..(cy + half))
}

/// The poses of `path` in the inclusive `range`, clamped to the path.
fn part(path: &[(f64, f64)], range: [usize; 2]) -> Vec<(f64, f64)> {
    let first = range[0].min(range[1]);
    let last = range[0].max(range[1]);
    if path.is_empty() || first >= path.len() {
        return Vec::new();
    }
    path[first..=last.min(path.len() - 1)].to_vec()
}

/// One line of the figure: points, colour, stroke width, legend label.
type Series<'a> = (&'a [(f64, f64)], RGBColor, u32, &'a str);

/// Colours of successive loops (best first), repeated past the tenth.
const LOOP_COLOURS: [RGBColor; 10] = [
    RGBColor(220, 30, 30),
    RGBColor(0, 90, 255),
    RGBColor(0, 150, 0),
    RGBColor(200, 0, 200),
    RGBColor(255, 140, 0),
    RGBColor(0, 170, 170),
    RGBColor(140, 80, 20),
    RGBColor(120, 120, 0),
    RGBColor(90, 0, 160),
    RGBColor(255, 60, 150),
];
const PATH_COLOUR: RGBColor = RGBColor(160, 160, 160);

/// The colour of the `i`-th loop or path ([`LOOP_COLOURS`], repeated).
fn nth_colour(i: usize) -> RGBColor {
    LOOP_COLOURS[i % LOOP_COLOURS.len()]
}

/// Draws the figure on `root`; errors as text (the backend's error types
/// differ).
fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    view: &View,
    figure: &Figure,
) -> std::result::Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let all: Vec<(f64, f64)> = figure.points().map(|p| view.project(p)).collect();
    let (x_range, y_range) = equal_ranges(&all);
    let font = ("sans-serif", 20).into_font().color(&BLACK);
    let small = ("sans-serif", 16).into_font().color(&BLACK);

    root.fill(&WHITE).map_err(err)?;
    let (title, body) = root.split_vertically(TITLE);
    let mut chart = ChartBuilder::on(&body)
        .margin(MARGIN)
        .x_label_area_size(X_LABELS)
        .y_label_area_size(Y_LABELS)
        .build_cartesian_2d(x_range, y_range)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(view.names[0])
        .y_desc(view.names[1])
        .light_line_style(WHITE.mix(0.0))
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    let Drawing {
        lines,
        legend,
        heading,
    } = match figure {
        Figure::Merge { a, b_in_a, h } => merge_drawing(view, a, b_in_a, h),
        Figure::Loops { path, loops } => loops_drawing(view, path, loops),
        Figure::Placement { paths, overlaps } => placement_drawing(view, paths, overlaps),
        Figure::Correction {
            before,
            after,
            loops,
        } => correction_drawing(view, before, after, loops),
    };
    for (points, colour, width) in &lines {
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                colour.stroke_width(*width),
            ))
            .map_err(err)?;
    }
    title
        .draw_text(&heading[0], &font, (MARGIN as i32, 8))
        .map_err(err)?;
    title
        .draw_text(&heading[1], &small, (MARGIN as i32, 34))
        .map_err(err)?;
    // The legend goes in the title band: inside the chart it would hide
    // part of a path, wherever it were put.
    let mut x = MARGIN as i32;
    let y = 72;
    let (right, _) = title.dim_in_pixel();
    for (colour, width, label) in legend {
        // A legend of many paths stops at the figure's edge.
        let (w, _) = title.estimate_text_size(&label, &small).map_err(err)?;
        if x + 30 + w as i32 > right as i32 {
            title.draw_text("...", &small, (x, y - 8)).map_err(err)?;
            break;
        }
        title
            .draw(&PathElement::new(
                vec![(x, y), (x + 24, y)],
                colour.stroke_width(width),
            ))
            .map_err(err)?;
        title
            .draw_text(&label, &small, (x + 30, y - 8))
            .map_err(err)?;
        x += 30 + w as i32 + 16;
    }
    root.present().map_err(err)
}

/// One drawn line: points, colour, stroke width.
type Line = (Vec<(f64, f64)>, RGBColor, u32);

/// One legend entry: colour, stroke width, label.
type LegendEntry = (RGBColor, u32, String);

/// What one figure draws: its lines in drawing order, its legend and its
/// two title lines.
struct Drawing {
    lines: Vec<Line>,
    legend: Vec<LegendEntry>,
    heading: [String; 2],
}

/// The projection of `points` into the figure.
fn project(view: &View, points: &[Vector3<f64>]) -> Vec<(f64, f64)> {
    points.iter().map(|p| view.project(p)).collect()
}

/// A merge: A, B in A's frame, both common parts and the correspondences.
fn merge_drawing(
    view: &View,
    a: &[Vector3<f64>],
    b_in_a: &[Vector3<f64>],
    h: &Hypothesis,
) -> Drawing {
    let (a2, b2) = (project(view, a), project(view, b_in_a));
    let series: [Series; 4] = [
        (&a2, A_COLOUR, 2, "A"),
        (&b2, B_COLOUR, 2, "B (in A's frame)"),
        (&part(&a2, h.a_range), A_COMMON, 7, "A common part"),
        (&part(&b2, h.b_range), B_COMMON, 3, "B common part"),
    ];
    let legend: Vec<LegendEntry> = series
        .iter()
        .map(|(_, colour, width, label)| (*colour, (*width).clamp(2, 5), label.to_string()))
        .chain([(BLACK, 1, "correspondences".to_string())])
        .collect();
    let mut lines: Vec<_> = series
        .iter()
        .map(|(points, colour, width, _)| (points.to_vec(), *colour, *width))
        .collect();
    lines.extend(links(h, &a2, &b2).map(|l| (l.to_vec(), BLACK, 1)));
    let heading = [
        format!(
            "score {:.3}   scale {:.4}   rmse {:.3} (A units){}",
            h.score,
            h.scale,
            h.rmse,
            if h.reversed { "   B reversed" } else { "" }
        ),
        format!(
            "common part: A poses {}-{} ~ B poses {}-{}, {} correspondences",
            h.a_range[0],
            h.a_range[1],
            h.b_range[0],
            h.b_range[1],
            h.correspondences.len()
        ),
    ];
    Drawing {
        lines,
        legend,
        heading,
    }
}

const KEPT_COLOUR: RGBColor = RGBColor(0, 150, 0);
const REJECTED_COLOUR: RGBColor = RGBColor(220, 30, 30);
const CORRECTED_COLOUR: RGBColor = RGBColor(0, 60, 255);

/// A correction: the path before (grey) and after (blue), and each loop as a
/// line between the middles of its two parts on the corrected path.
fn correction_drawing(
    view: &View,
    before: &[Vector3<f64>],
    after: &[Vector3<f64>],
    loops: &[LoopMark],
) -> Drawing {
    let (b2, a2) = (project(view, before), project(view, after));
    let mut lines = vec![(b2, PATH_COLOUR, 2), (a2.clone(), CORRECTED_COLOUR, 2)];
    let middle = |r: [usize; 2]| a2.get((r[0] + r[1]) / 2).copied();
    // Rejected loops first and thinner: a search's look-alikes outnumber
    // its loops and hid the kept ones under them.
    let mut order: Vec<&LoopMark> = loops.iter().collect();
    order.sort_by_key(|l| l.2);
    for &&(query, matched, kept) in &order {
        let (colour, width) = if kept {
            (KEPT_COLOUR, 5)
        } else {
            (REJECTED_COLOUR, 3)
        };
        lines.push((part(&a2, query), colour, width));
        if let (Some(q), Some(m)) = (middle(query), middle(matched)) {
            lines.push((vec![q, m], colour, width / 2));
        }
    }
    let kept = loops.iter().filter(|l| l.2).count();
    let legend = vec![
        (PATH_COLOUR, 2, "before".to_string()),
        (CORRECTED_COLOUR, 2, "corrected".to_string()),
        (KEPT_COLOUR, 4, "loop kept".to_string()),
        (REJECTED_COLOUR, 3, "loop rejected".to_string()),
    ];
    let heading = [
        format!("drift correction: {} poses", after.len()),
        format!("{kept} loops kept, {} rejected", loops.len() - kept),
    ];
    Drawing {
        lines,
        legend,
        heading,
    }
}

/// A placement: each merged path in its own colour, the common parts of
/// the overlaps used wide, in the colours of their two paths.
fn placement_drawing(view: &View, paths: &[Placed], overlaps: &[OverlapMark]) -> Drawing {
    let projected: Vec<Option<Vec<(f64, f64)>>> = paths
        .iter()
        .map(|p| p.as_deref().map(|p| project(view, p)))
        .collect();
    let mut lines = Vec::new();
    for &(a, b, a_range, b_range) in overlaps {
        for (k, range) in [(a, a_range), (b, b_range)] {
            if let Some(Some(p2)) = projected.get(k) {
                lines.push((part(p2, range), lighter(nth_colour(k)), 7));
            }
        }
    }
    for (k, p2) in projected.iter().enumerate() {
        if let Some(p2) = p2 {
            lines.push((p2.clone(), nth_colour(k), 2));
        }
    }
    let legend = projected
        .iter()
        .enumerate()
        .filter(|(_, p)| p.is_some())
        .map(|(k, _)| (nth_colour(k), 3, format!("P{}", k + 1)))
        .collect();
    let placed = projected.iter().filter(|p| p.is_some()).count();
    let left_out: Vec<String> = projected
        .iter()
        .enumerate()
        .filter(|(_, p)| p.is_none())
        .map(|(k, _)| format!("P{}", k + 1))
        .collect();
    let heading = [
        format!(
            "{placed} of {} paths placed in P1's frame; wide: the overlaps that placed them",
            paths.len()
        ),
        if left_out.is_empty() {
            "every path merged".to_string()
        } else {
            format!("not merged: {}", left_out.join(", "))
        },
    ];
    Drawing {
        lines,
        legend,
        heading,
    }
}

/// Loops: the path, and per loop its two parts and correspondences.
fn loops_drawing(view: &View, path: &[Vector3<f64>], loops: &[Hypothesis]) -> Drawing {
    let p2 = project(view, path);
    let mut lines = vec![(p2.clone(), PATH_COLOUR, 2)];
    // The best loop drawn last, on top; each query (later) part
    // wide, the part it revisits thinner and lighter.
    for (i, h) in loops.iter().enumerate().rev() {
        lines.push((part(&p2, h.a_range), nth_colour(i), 6));
        lines.push((part(&p2, h.b_range), lighter(nth_colour(i)), 3));
        lines.extend(links(h, &p2, &p2).map(|l| (l.to_vec(), nth_colour(i), 1)));
    }
    let legend = loops
        .iter()
        .enumerate()
        .map(|(i, h)| (nth_colour(i), 4, format!("#{}", h.rank)))
        .collect();
    let scores: Vec<String> = loops.iter().map(|h| format!("{:.2}", h.score)).collect();
    let heading = [
        format!(
            "{} loops of {} poses: wide, the later part; thin, the part it revisits",
            loops.len(),
            path.len()
        ),
        format!("scores, best first: {}", scores.join("  ")),
    ];
    Drawing {
        lines,
        legend,
        heading,
    }
}

/// `c` halfway to white.
fn lighter(c: RGBColor) -> RGBColor {
    let half = |v: u8| ((v as u16 + 255) / 2) as u8;
    RGBColor(half(c.0), half(c.1), half(c.2))
}

/// At most [`MAX_CORRESPONDENCE_LINES`] of `h`'s correspondences, evenly
/// spaced, as segments from A's point to B's.
fn links<'a>(
    h: &'a Hypothesis,
    a2: &'a [(f64, f64)],
    b2: &'a [(f64, f64)],
) -> impl Iterator<Item = [(f64, f64); 2]> + 'a {
    let step = h
        .correspondences
        .len()
        .div_ceil(MAX_CORRESPONDENCE_LINES)
        .max(1);
    h.correspondences
        .iter()
        .step_by(step)
        .filter_map(|&(i, j)| Some([*a2.get(i)?, *b2.get(j)?]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn circle(f: impl Fn(f64, f64) -> Vector3<f64>) -> Vec<Vector3<f64>> {
        (0..100)
            .map(|i| {
                let t = i as f64 * 0.0628;
                f(3.0 * t.cos(), t.sin())
            })
            .collect()
    }

    #[test]
    fn planar_paths_keep_their_coordinate_axes() {
        let xy = View::of(&circle(|u, v| Vector3::new(u, v, 0.01 * u)));
        assert_eq!(xy.names, ["x", "y"]);
        let xz = View::of(&circle(|u, v| Vector3::new(u, 0.5, v)));
        assert_eq!(xz.names, ["x", "z"]);
        let yz = View::of(&circle(|u, v| Vector3::new(2.0, u, v)));
        assert_eq!(yz.names, ["y", "z"]);
    }

    #[test]
    fn tilted_paths_use_the_principal_axes_of_their_plane() {
        // The plane z = x (45 degrees): the long axis (along u) comes first.
        let view = View::of(&circle(|u, v| Vector3::new(u, v, u)));
        assert_eq!(view.names[0], "plane axis 1");
        let along_u = Vector3::new(1.0, 0.0, 1.0).normalize();
        assert!(view.axes[0].dot(&along_u).abs() > 0.999);
        assert!(view.axes[1].y.abs() > 0.999);
        assert!(view.axes[0].dot(&view.axes[1]).abs() < 1e-12);
    }

    #[test]
    fn ranges_are_square_and_hold_every_point() {
        let (x, y) = equal_ranges(&[(0.0, 0.0), (10.0, 2.0), (4.0, -1.0)]);
        assert!(((x.end - x.start) - (y.end - y.start)).abs() < 1e-12);
        assert!(x.start < 0.0 && x.end > 10.0 && y.start < -1.0 && y.end > 2.0);
        let (x, _) = equal_ranges(&[(5.0, 5.0)]);
        assert!(x.end > x.start);
    }

    #[test]
    fn parts_are_clamped_to_the_path() {
        let path: Vec<(f64, f64)> = (0..10).map(|i| (i as f64, 0.0)).collect();
        assert_eq!(part(&path, [2, 4]).len(), 3);
        assert_eq!(part(&path, [8, 20]).len(), 2);
        assert!(part(&path, [12, 20]).is_empty());
    }
}
