//! The batch pipeline: `match`, `loops` and `merge` strung from the stages.
//!
//! ```text
//! prepare (plane, track, signature, segments)   for each path
//! search  (ZNCC of N = 2..12 segments, pooled by alignment line)
//! verify  (RANSAC, grow, refit, evidence)        strongest candidates first
//! score, rank (de-duplicate, top k)
//! ```

pub mod alike;
pub mod coincidence;
pub mod config;
pub mod merge;
pub mod placement;
pub mod prepare;
pub mod proximity;
pub mod rank;
pub mod refine;
pub mod resolution;
pub mod upright;
pub mod verify;

pub use config::Config;
pub use merge::merge;
pub use placement::{merge_many, Placement};
pub use prepare::PreparedPath;
pub use verify::Verified;

use nalgebra::Vector3;

use crate::matching::candidates::{queries, search, to_verify};
use crate::matching::turns::{propose, turns};
use crate::matching::Correlator;
use crate::score::{loop_score, score};
use crate::track::Track;
use crate::{Hypothesis, Result, Trajectory};
use rank::Duplicates;

/// Where path B overlaps path A, best first (at most `config.top_k`).
pub fn match_paths(a: &Trajectory, b: &Trajectory, config: &Config) -> Result<Vec<Hypothesis>> {
    // Each path through plane, track, signature and segments.
    let pa = PreparedPath::new(a, config)?;
    let pb = PreparedPath::new(b, config)?;
    Ok(match_across_rates(a, b, &pa, &pb, config))
}

/// Each hypothesis' similarity polished on the raw poses `a` and `b`
/// ([`crate::align::polish()`]).
fn polished(
    a: &[Vector3<f64>],
    b: &[Vector3<f64>],
    mut hypotheses: Vec<Hypothesis>,
) -> Vec<Hypothesis> {
    if hypotheses.is_empty() || a.is_empty() || b.is_empty() {
        return hypotheses;
    }
    let raw_a = crate::align::RawPath::new(a);
    for h in &mut hypotheses {
        let window = crate::align::search_window(h.a_range);
        let a_t_b = crate::align::polish(
            &raw_a,
            window,
            b,
            h.b_range,
            &h.similarity(),
            crate::align::Fit::Similarity,
        );
        h.scale = a_t_b.scale;
        h.rotation = a_t_b.rotation;
        h.translation = a_t_b.translation;
    }
    hypotheses
}

/// [`match_prepared`], and when one path is sampled several times more
/// densely than the other, the same again with the denser one thinned to
/// the other's rate ([`resolution`]); the hypotheses of both ranked
/// together, in the original pose indices, their similarities polished on
/// the raw poses.
pub fn match_across_rates(
    a: &Trajectory,
    b: &Trajectory,
    pa: &PreparedPath,
    pb: &PreparedPath,
    config: &Config,
) -> Vec<Hypothesis> {
    // Both paths at their own rates.
    let mut all = match_prepared(pa, pb, config);
    // The denser one thinned to the other's rate, where they differ.
    all.extend(match_thinned(a, b, pa, pb, config));
    // Nothing convincing: each smoothed wider, where that makes them alike.
    if all.iter().all(|h| h.score < alike::ALIKE_BELOW_SCORE) {
        all.extend(alike::match_smoothed_alike(pa, pb, config));
    }
    let ranked = rank::rank(all, config.top_k, config.min_score, Duplicates::Alignment);
    // The reported similarities, refined on the raw poses.
    polished(&pa.positions, &pb.positions, ranked)
}

/// The hypotheses of the denser path thinned to the sparser one's rate,
/// in the original pose indices (none when the rates are alike).
fn match_thinned(
    a: &Trajectory,
    b: &Trajectory,
    pa: &PreparedPath,
    pb: &PreparedPath,
    config: &Config,
) -> Vec<Hypothesis> {
    let ratio = resolution::density_ratio(pa, pb);
    let Some(k) = resolution::thinning(ratio) else {
        return Vec::new();
    };
    let a_denser = ratio >= 1.0;
    let dense = if a_denser { a } else { b };
    let mut all = Vec::new();
    for k in resolution::thinnings_around(k) {
        let Ok(thin) = PreparedPath::new(&resolution::thinned(dense, k), config) else {
            continue;
        };
        let mut coarse = match a_denser {
            true => match_prepared(&thin, pb, config),
            false => match_prepared(pa, &thin, config),
        };
        let at = |i: usize| resolution::unthinned(i, k, dense.len());
        for h in &mut coarse {
            if a_denser {
                h.a_range = h.a_range.map(at);
                h.correspondences.iter_mut().for_each(|c| c.0 = at(c.0));
            } else {
                h.b_range = h.b_range.map(at);
                h.correspondences.iter_mut().for_each(|c| c.1 = at(c.1));
            }
        }
        all.extend(coarse);
    }
    all
}

/// The hypotheses of prepared paths at their own rates, ranked, their
/// similarities as grown and lifted ([`match_across_rates`] adds the
/// thinned match and the polish).
pub fn match_prepared(pa: &PreparedPath, pb: &PreparedPath, config: &Config) -> Vec<Hypothesis> {
    match_prepared_within(pa, pb, None, config)
}

/// [`match_prepared`] verifying only the candidates whose scale (B onto A)
/// may lie within `scales` (`[least, most]`): a ZNCC candidate's scale is
/// read from the arc lengths of its aligned ranges, a turn pair's is
/// exact. Where the caller keeps only hypotheses of a known scale range
/// ([`alike`]), the others' verification is not paid for.
pub fn match_prepared_within(
    pa: &PreparedPath,
    pb: &PreparedPath,
    scales: Option<[f64; 2]>,
    config: &Config,
) -> Vec<Hypothesis> {
    if pa.signature.len() < 3 || pb.signature.len() < 3 {
        return Vec::new();
    }
    // B's queries against A's whole signature, pooled by alignment line.
    // B's queries against A's whole signature and A's against B's (a query
    // longer than the other path, or than the common part, finds nothing),
    // pooled by alignment line, A's votes turned into B-query form.
    let (sa, sb) = (&pa.signature, &pb.signature);
    let to_a = Correlator::new(&sa.value, sb.len());
    let mut candidates = search(
        &to_a,
        &sb.value,
        &queries(&pb.bounds, sb.len(), sb.dk, &config.query),
        &config.query,
        |_| true,
    );
    let to_b = Correlator::new(&sb.value, sa.len());
    candidates.extend(
        search(
            &to_b,
            &sa.value,
            &queries(&pa.bounds, sa.len(), sa.dk, &config.query),
            &config.query,
            |_| true,
        )
        .iter()
        .filter_map(|c| c.swapped(sb.len())),
    );
    // A scale not read (NaN) is kept.
    let within = |scale: f64| scales.is_none_or(|[lo, hi]| !(scale < lo || scale > hi));
    candidates.sort_by(|x, y| y.strength.total_cmp(&x.strength));
    // Turn pairs: proposals that do not depend on aligning K.
    let tc = &config.turns;
    let mut proposals = propose(
        &turns(&pa.track, &pa.signature, tc),
        &turns(&pb.track, &pb.signature, tc),
        tc,
    );
    proposals.retain(|p| within(p.a_T_b.scale));
    // Geometry decides, on every core: the strongest ZNCC candidates and
    // the turn-pair proposals, verified the same way.
    let xy = [pb.points(false), pb.points(true)];
    // The budget is spent as without `scales`; the candidates out of them
    // are then dropped unverified.
    let jobs: Vec<Job> = worth_verifying(&candidates, config)
        .into_iter()
        .filter(|c| within(candidate_scale(sa, sb, c)))
        .map(Job::Zncc)
        .chain(proposals.iter().map(Job::Turns))
        .collect();
    let hypotheses = crate::parallel::map(&jobs, |job| match job {
        Job::Zncc(cand) => {
            let mirrored = cand.orientation.mirrored;
            verify::verify_best(pa, pb, &xy[mirrored as usize], cand, config, &|_, _| true)
                .map(|(v, _)| to_hypothesis(pa, pb, &v, Some(&config.score)))
        }
        Job::Turns(p) => {
            let seed = [p.seed[0], p.seed[1].min(pb.track.len() - 1)];
            verify::verify_seeded(
                pa,
                pb,
                &xy[p.mirrored as usize],
                seed,
                p.a_T_b,
                p.mirrored,
                config,
                &|_, _| true,
            )
            .map(|v| to_hypothesis(pa, pb, &v, Some(&config.score)))
        }
    });
    rank::rank(
        hypotheses,
        config.top_k,
        config.min_score,
        Duplicates::Alignment,
    )
}

/// Scale of a ZNCC candidate (B onto A): the arc length of its target
/// range over its query range's. Aligned in `K`, a true overlap's ranges
/// differ in length by the similarity's scale (up to the smoothing); an
/// empty range reads as any scale.
fn candidate_scale(
    sa: &crate::signature::Signature,
    sb: &crate::signature::Signature,
    c: &crate::matching::Candidate,
) -> f64 {
    let clamp = |t: i64| t.clamp(0, sa.len() as i64 - 1) as usize;
    let (t0, t1) = (
        clamp(c.target_of(c.query[0])),
        clamp(c.target_of(c.query[1])),
    );
    let along_a = (sa.s[t0] - sa.s[t1]).abs();
    let along_b = sb.s[c.query[1]] - sb.s[c.query[0]];
    if along_a > 0.0 && along_b > 0.0 {
        along_a / along_b
    } else {
        f64::NAN
    }
}

/// The shape candidates to verify under `config`'s budget.
fn worth_verifying<'a>(
    candidates: &'a [crate::matching::Candidate],
    config: &Config,
) -> Vec<&'a crate::matching::Candidate> {
    to_verify(
        candidates,
        config.max_candidates,
        config.max_zncc_candidates,
        config.query.line_tolerance,
    )
}

/// One verification to run.
enum Job<'a> {
    Zncc(&'a crate::matching::Candidate),
    Turns(&'a crate::matching::turns::TurnProposal),
}

/// One loop verification to run.
enum LoopJob<'a> {
    Zncc(&'a crate::matching::Candidate),
    Proximity(&'a proximity::ProximitySeed),
}

/// Places that path A revisits. `a_range` is the later (query) part,
/// `b_range` the earlier (match) part; the similarity maps match onto query.
pub fn find_loops(a: &Trajectory, config: &Config) -> Result<Vec<Hypothesis>> {
    let pa = PreparedPath::new(a, config)?;
    Ok(find_loops_prepared(&pa, config))
}

/// [`find_loops`] on a prepared path.
pub fn find_loops_prepared(pa: &PreparedPath, config: &Config) -> Vec<Hypothesis> {
    let sig = &pa.signature;
    if sig.len() < 3 {
        return Vec::new();
    }
    let margin = (config.loop_exclusion / sig.dk).round() as i64;
    // A query never matches its own neighbourhood: the aligned target range
    // must stay clear of the query range by `margin` samples of K.
    let clear = |c: &crate::matching::Candidate| {
        let (q0, q1) = (c.query[0] as i64, c.query[1] as i64);
        let (t0, t1) = {
            let (x, y) = (c.target_of(c.query[0]), c.target_of(c.query[1]));
            (x.min(y), x.max(y))
        };
        t1 < q0 - margin || t0 > q1 + margin
    };
    let mut query = config.query;
    query.mirror = false;
    let correlator = Correlator::new(&sig.value, sig.len());
    let ranges = queries(&pa.bounds, sig.len(), sig.dk, &query);
    let candidates = search(&correlator, &sig.value, &ranges, &query, clear);
    let xy = pa.points(false);
    let track = &pa.track;
    // Grown points stay away from themselves along the path by at least the
    // seed's own length.
    let away = |seed_len: f64| {
        move |g: usize, v: f64| (track.s[g] - Track::interp(&track.s, v)).abs() > seed_len
    };
    // Proximity seeds: the map's own frame, starting from the identity; or,
    // where only the drift prior's wider radius finds the earlier part,
    // from the similarity of the probe points onto their nearest points.
    let drift = config.drift_prior.map_or(0.0, |p| p.position);
    let seeds = proximity::proximity_seeds(pa, drift);
    let jobs: Vec<LoopJob> = worth_verifying(&candidates, config)
        .into_iter()
        .map(LoopJob::Zncc)
        .chain(seeds.iter().map(LoopJob::Proximity))
        .collect();
    // Shape candidates and proximity seeds verified the same way, on every
    // core.
    let verified = crate::parallel::map(&jobs, |job| match job {
        LoopJob::Zncc(cand) => {
            let seed_len = sig.s[cand.seed[1]] - sig.s[cand.seed[0]];
            verify::verify_best(pa, pa, &xy, cand, config, &away(seed_len)).map(|(v, _)| v)
        }
        LoopJob::Proximity(seed) => {
            let seed_len = track.s[seed.query[1]] - track.s[seed.query[0]];
            seed.starts(seed_len).find_map(|start| {
                verify::verify_seeded(
                    pa,
                    pa,
                    &xy,
                    seed.query,
                    start,
                    false,
                    config,
                    &away(seed_len),
                )
            })
        }
    });
    let mut hypotheses = Vec::new();
    let extent = crate::geometry::extent(&pa.positions);
    for v in &verified {
        let h = to_hypothesis(pa, pa, v, None);
        let s = match &config.drift_prior {
            Some(prior) => {
                let length = v.overlap.target_length.max(v.overlap.query_length);
                let between = (track.s[track.grid_of_pose(h.a_range[0]) as usize]
                    - track.s[track.grid_of_pose(h.b_range[1]) as usize])
                    .abs();
                let offset = median_offset(pa, &h);
                let p = prior.factor(h.rotation_angle(), h.scale, offset, length, between);
                loop_score(&v.evidence, p, &config.score)
                    * coincidence::coincidence_factor(offset, extent)
            }
            None => score(&v.evidence, &config.score),
        };
        hypotheses.push(Hypothesis { score: s, ..h });
    }
    // Not polished (`align::polish`): two passes over one road in one map
    // differ by lane and line, which a point-to-line fit follows away from
    // the consistent map's near-identity (ground truth of 00-08, 15
    // correct loops: median error 0.75 m as grown, 1.81 m polished).
    rank::rank(
        hypotheses,
        config.top_k,
        config.min_score,
        Duplicates::Place,
    )
}

/// Median distance in the map between corresponding poses of a loop, in
/// 3D: the smoothed track in the path's plane at the poses' heights above
/// it. The plane drops the height, so measured in it alone two passes over
/// one spot of the floor at different heights were one place to the drift
/// prior: a drone's lap half a metre higher outranked the lap at its own
/// height (on the drones' truths, seed 1, it takes 3 of 10 wrong rank-1s
/// right, and 1 of 3 in the TUM-VI rooms; issue 39). A
/// planar path's heights are about constant, so its offsets are as before
/// (KITTI loops unchanged).
fn median_offset(pa: &PreparedPath, h: &Hypothesis) -> f64 {
    let at = |pose: usize| pa.point3_at(pa.track.grid_of_pose(pose));
    let mut d: Vec<f64> = h
        .correspondences
        .iter()
        .map(|&(a, b)| (at(a) - at(b)).norm())
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// A verified overlap as a hypothesis in 3D. Between two paths (`merge`:
/// scored with `merge`), its evidence is measured on the 3D fit where that
/// fits closer than the 2D one, and a match held turned over loses score
/// ([`upright`]). For loops (`merge` `None`, score left to the caller), the
/// later part becomes A (the query) and the similarity maps the earlier part
/// onto it.
fn to_hypothesis(
    pa: &PreparedPath,
    pb: &PreparedPath,
    v: &Verified,
    merge: Option<&crate::score::ScoreConfig>,
) -> Hypothesis {
    let later_is_a = merge.is_none();
    let o = &v.overlap;
    let mirrored = v.candidate.orientation.mirrored;
    let lifted = pa.plane.lift(&pb.plane(mirrored), &o.a_T_b);
    // Each plane is its whole path's: the common road's own 3D points fix
    // the tilt between them.
    let step = (o.pairs.len() / 200).max(1);
    let points: Vec<_> = o
        .pairs
        .iter()
        .step_by(step)
        .map(|&(t, q)| (pa.point3_at(t), pb.point3_at(q as f64)))
        .collect();
    let mut a_t_b = crate::align::refine_lift(&lifted, &points);
    let length = o.target_length.max(o.query_length);
    let (score, rmse) = match merge {
        None => (0.0, o.rmse),
        Some(config) => {
            // Two windows of one hilly road fit planes tilted apart, and each
            // sees the road foreshortened its own way: the 2D misfit then
            // measures the tilt, not the match (KITTI 09, one road in two
            // windows: 0.1-0.3 m in 2D by where the windows start).
            let rmse = o.rmse.min(crate::align::rms_residual(&a_t_b, &points));
            let evidence = crate::score::Evidence {
                relative_rmse: rmse / length.max(f64::MIN_POSITIVE),
                ..v.evidence
            };
            // Either path may be seen from the other side of its plane.
            let upright = upright::upright_factor(&points, &a_t_b, &pa.plane.normal());
            (score(&evidence, config) * upright, rmse)
        }
    };
    let mut a_range = [pa.pose_of_grid(o.target[0]), pa.pose_of_grid(o.target[1])];
    let mut b_range = [
        pb.pose_of_grid(o.query[0] as f64),
        pb.pose_of_grid(o.query[1] as f64),
    ];
    let step = (o.pairs.len() / 50).max(1);
    let mut correspondences: Vec<(usize, usize)> = o
        .pairs
        .iter()
        .step_by(step)
        .map(|&(t, q)| (pa.pose_of_grid(t), pb.pose_of_grid(q as f64)))
        .collect();
    if later_is_a && b_range[0] > a_range[0] {
        std::mem::swap(&mut a_range, &mut b_range);
        a_t_b = a_t_b.inverse();
        for c in &mut correspondences {
            *c = (c.1, c.0);
        }
    }
    Hypothesis {
        rank: 0,
        score,
        zncc: v.evidence.zncc,
        reversed: v.candidate.orientation.reversed,
        a_range,
        b_range,
        scale: a_t_b.scale,
        rotation: a_t_b.rotation,
        translation: a_t_b.translation,
        rmse,
        turning: v.evidence.turning,
        length,
        length_ratio: v.evidence.length_ratio,
        correspondences,
    }
}
