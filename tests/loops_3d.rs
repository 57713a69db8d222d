//! Loops of paths off the ground plane, named after the bug: the loop
//! search works in the path's plane, and what it drops there (the height)
//! must still tell two places apart.

use nalgebra::Vector3;
use turnprint::pipeline::{find_loops, Config};
use turnprint::Trajectory;

/// Points about half a unit apart along the polyline through `corners`
/// (the last corner left out), at heights from `z0` to `z1` along it.
fn polyline(corners: &[(f64, f64)], z0: f64, z1: f64) -> Vec<Vector3<f64>> {
    let mut flat = Vec::new();
    for w in corners.windows(2) {
        let (a, b): ((f64, f64), (f64, f64)) = (w[0], w[1]);
        let n = ((b.0 - a.0).hypot(b.1 - a.1) / 0.5).ceil() as usize;
        for i in 0..n {
            let t = i as f64 / n as f64;
            flat.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
        }
    }
    let n = flat.len().max(2) as f64 - 1.0;
    flat.iter()
        .enumerate()
        .map(|(i, &(x, y))| Vector3::new(x, y, z0 + (z1 - z0) * i as f64 / n))
        .collect()
}

/// One lap of a notched rectangle (perimeter 116 units, five turns of
/// distinct sharpness) from the origin back to it.
const LAP: [(f64, f64); 7] = [
    (0.0, 0.0),
    (40.0, 0.0),
    (40.0, 12.0),
    (28.0, 12.0),
    (22.0, 20.0),
    (0.0, 20.0),
    (0.0, 0.0),
];

/// The lap flown three times: the first turned `first_off_deg` about the
/// origin, the second `height` higher and `beside` units to the south-east
/// (no side of it on a side of the others), with a different detour from
/// the lap's start and back between laps (south-west, then west), on which
/// the height changes: no two stretches of laps and detours look alike, so
/// each lap can only be matched with another lap.
fn three_laps(height: f64, beside: f64, first_off_deg: f64) -> Vec<Vector3<f64>> {
    let south = [
        (0.0, 0.0),
        (-6.0, -10.0),
        (4.0, -18.0),
        (-10.0, -26.0),
        (0.6 * beside, -0.8 * beside),
    ];
    let west = [
        (0.6 * beside, -0.8 * beside),
        (-14.0, 4.0),
        (-20.0, 16.0),
        (-30.0, 8.0),
        (0.0, 0.0),
    ];
    // The first pass a little off the later two (turned `first_off_deg`
    // about the origin), as no two passes of a place agree exactly; the
    // second lap is the third's exact copy in shape.
    let (c, s) = (
        first_off_deg.to_radians().cos(),
        first_off_deg.to_radians().sin(),
    );
    let first = polyline(&LAP, 0.0, 0.0)
        .iter()
        .map(|p| Vector3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z))
        .collect();
    let second = polyline(&LAP, height, height)
        .iter()
        .map(|p| p + Vector3::new(0.6 * beside, -0.8 * beside, 0.0))
        .collect();
    [
        first,
        polyline(&south, 0.0, height),
        second,
        polyline(&west, height, 0.0),
        polyline(&LAP, 0.0, 0.0),
    ]
    .concat()
}

/// Median 3D distance between the rank-1 loop's corresponding poses.
fn rank1_offset(path: &[Vector3<f64>]) -> f64 {
    let loops = find_loops(
        &Trajectory::from_positions("three laps", path),
        &Config::for_loops(),
    )
    .expect("the laps are a path");
    let best = loops.first().expect("the laps revisit");
    median_offset(path, &best.correspondences)
}

/// Median 3D distance between a loop's corresponding poses.
fn median_offset(path: &[Vector3<f64>], pairs: &[(usize, usize)]) -> f64 {
    let mut d: Vec<f64> = pairs
        .iter()
        .map(|&(a, b)| (path[a] - path[b]).norm())
        .collect();
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// A drone flies one floor plan three times, the middle lap 8 units higher
/// (two fifths of the plan's width). In the path's plane the three laps are
/// one; in 3D only the first and the third are one place. The drift prior
/// measured the offset of a loop's passes in the plane, where the high lap
/// is the third's exact copy and the first is 1.5° off, so the third lap
/// matched with the high one ranked first, 8 units apart (issue 39: on the
/// drones' truths, seed 1, 10 of 17 rank-1 loops were wrong).
#[test]
fn loops_at_another_height_are_not_the_same_place() {
    // 1.5°: up to 1.2 units at the far corner.
    let offset = rank1_offset(&three_laps(8.0, 0.0, 1.5));
    assert!(offset < 2.0, "rank-1 passes {offset:.2} apart in 3D");
}

/// The same flight with the middle lap at the others' height but 6 units
/// to the south-east (7 % of the path's extent) and the first pass 5° off:
/// a lap beside the place, as a drone circling a room flies beside its
/// earlier laps. The drift prior lets passes lie 10 % of their matched
/// length apart (11 units here) at little cost, so the exact copy beside
/// outranked the place itself (issue 39: with the offset in 3D, 7 of the
/// drones' 17 rank-1 loops on their truths were still wrong, most a lap
/// 3-8 revisit radii beside or above the place).
#[test]
fn loops_beside_the_place_are_not_the_same_place() {
    // 5°: up to 3.9 units at the far corner, 1.9 at the median.
    let offset = rank1_offset(&three_laps(0.0, 6.0, 5.0));
    assert!(offset < 3.0, "rank-1 passes {offset:.2} apart");
}
