//! Settings of the online detector. Like the batch settings, every
//! tolerance is in radians, ratios, counts or multiples of the typical pose
//! spacing measured during warm-up: none is in metres.

use crate::pipeline::Config;

/// How much of the query's own neighbourhood a match must stay clear of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Exclusion {
    /// Turning (radians of `K`) between the match and the query.
    Turning(f64),
    /// Whole segments between the match and the query.
    Segments(usize),
}

/// Settings of [`super::Detector`].
#[derive(Debug, Clone)]
pub struct OnlineConfig {
    /// The batch stages' settings (signature, segments, queries, alignment,
    /// score, drift prior). Defaults to [`Config::for_loops`].
    pub pipeline: Config,
    /// Poses buffered before the plane, the stationary threshold, the grid
    /// step and the smoothing bandwidth are chosen (GCV on this prefix).
    pub warmup_min_poses: usize,
    /// The warm-up also waits until the prefix spans a plane (second
    /// eigenvalue of its scatter at least `plane_ratio` times the third), up
    /// to this many poses; past them, until its newest `warmup_min_poses`
    /// poses are moving (not idling with jitter).
    pub warmup_max_poses: usize,
    /// See `warmup_max_poses`.
    pub plane_ratio: f64,
    /// The query's own neighbourhood.
    pub exclusion: Exclusion,
    /// Candidates emitted per finalised segment.
    pub top_k: usize,
    /// Lowest score emitted of a shape candidate; a proximity candidate's
    /// cut is a third of it (`gate::PROXIMITY_CUT_SHARE`).
    pub min_score: f64,
    /// Lowest score emitted for a candidate of the drifting-map probe. Its
    /// score is low by design (a straight revisit has little turning, and
    /// drift puts its similarity far from identity: KITTI 08's monocular
    /// revisit scores 0.0055 once grown along the road, its scale 1.29 off),
    /// and it has passed the probe's fit check; the verifier is its judge.
    pub drift_min_score: f64,
    /// Largest squared Mahalanobis distance emitted of a candidate's angle
    /// and offset under the drift prior along the path between its two
    /// parts ([`super::drift_path`]): a look-alike road within the drift's
    /// reach is laid there by a turn and a shift that drift does not pair.
    /// Strong drift, seeds 1-40 (held out 41-80): 409 (396) of 440 events
    /// at a share of correct candidates of 0.35 (0.36) without it and the
    /// path's prior, 411 (406) at 0.47 (0.47) with both; a cut of 4.5 gave
    /// 410 (404) at 0.48 but lost KITTI 08's monocular revisit.
    pub drift_path_cut: f64,
    /// Shape candidates verified per finalised segment (strongest first).
    pub max_verify: usize,
    /// Skip growth that cannot end emitted: a shape candidate whose
    /// drift-prior bound cannot reach `min_score` (the same candidates are
    /// emitted, at a quarter of the time), or that scores under a tenth of
    /// it after the first grow round (`search::FIRST_ROUND_CUT`: the same
    /// candidates on every evaluation path, worker instructions streaming
    /// KITTI 00 188.5 M -> 175.0 M), and a drifting source's start whose
    /// scale growth cannot bring within `gate::DRIFT_SCALE` (175.0 M ->
    /// 163.0 M). Off only to check those claims
    /// (`tests/online_gate.rs`).
    pub prior_gate: bool,
    /// Also search near the current position in the map's own frame.
    pub proximity: bool,
    /// Where the proximity probe finds nothing near, probe again with a
    /// radius growing with the path between the two parts (the drift
    /// prior's position rate), for maps that drift strongly: at segment
    /// boundaries and on every other periodic probe. On KITTI it finds one
    /// of the two revisits of 08's monocular estimate, which ORB-SLAM2 never
    /// closed, and 2.25 more of 11 strong-drift events on average (4 against
    /// 1.75, seeds 1-4); on consistent maps its candidates are other roads
    /// nearby (share of correct candidates 1.00 -> 0.89 on ground truth).
    /// Where it finds a road but nothing is emitted (a proximity candidate
    /// below the cut, emitted by this probe's rules, aside), the newest
    /// stretch is also placed on the whole road network
    /// ([`super::network`]; strong drift 18 -> 37 of 44 events, 397 of 440
    /// over seeds 1-40, 406 since it looks for the map's first road, 409
    /// since a short margin's rival is emitted wherever the probe found
    /// the road, 411 since placements are weighed by the drift prior along
    /// the path between; share on ground truth 0.89 -> 0.61 -> 0.75).
    pub drift_probe: bool,
    /// Between segments, probe the proximity every this many new track
    /// samples (half typical steps), over the newest twice as many.
    pub probe_every: usize,
    /// Messages the worker's queue holds before the caller starts merging
    /// (see [`super::worker`] for the overflow policy). With
    /// [`super::Overflow::Block`] the caller waits instead of merging, and
    /// the queue is deeper (the worker module says how).
    pub queue_capacity: usize,
    /// Matching threads over the one history: the matchings of the
    /// hand-overs queued at once are shared out among them
    /// ([`super::worker`]); the candidates (in the same order) and the
    /// memory are the same with any number. 1 for a detector embedded
    /// beside odometry, which needs its cores (and whose queue seldom holds
    /// two hand-overs); 2 for a replay (`turnprint stream`), which wants
    /// throughput.
    pub workers: usize,
    /// A step longer than this many typical steps is a jump (GPS glitch,
    /// VO failure) and goes through the jump filter.
    pub jump_factor: f64,
    /// Signature samples per block of the history correlator.
    pub block_len: usize,
}

impl Default for OnlineConfig {
    fn default() -> Self {
        OnlineConfig {
            pipeline: {
                let mut c = Config::for_loops();
                // Half the batch's points per grow round: the growth follows
                // the road as well, at half the nearest-point queries (on
                // KITTI 00 streamed: 27 -> 21 ms; detection unchanged on
                // GT and ORB, one more strong-drift event).
                c.grow.points_per_seed = 60;
                // The same cap on the points a later round re-projects inside
                // the grown range (about 86 a round on average, up to 190):
                // KITTI 00 streamed, 679 -> 629 M instructions; GT and ORB
                // candidates the same in number and delay, strong drift at
                // 1, 0.5 and 0.25 of its strength the same events (40 of 60
                // points: GT delay 35.9 -> 40.7 m).
                c.grow.points_per_round = 60;
                // And a refit that moves no point by a tenth of the
                // tolerance ends the rounds: the growth creeps by a sample
                // or two per round and kept most overlaps for all 8 rounds
                // (KITTI 00 streamed: 897 -> 699 M instructions under
                // callgrind; detection unchanged on GT, ORB and strong
                // drift; 0.2: 629 M, but the GT delay 35.9 -> 40.7 m).
                c.grow.settle = 0.1;
                // The batch loops' wider first band (5 %) takes in the road
                // a revisit came from while the overlap is still short,
                // which the detector sees first: on GT the first candidate
                // of an event then scores below the cut (delay 36 -> 51 m).
                c.grow.tolerance = crate::align::grow::GrowConfig::default().tolerance;
                c
            },
            warmup_min_poses: 200,
            warmup_max_poses: 3000,
            plane_ratio: 25.0,
            exclusion: Exclusion::Turning(std::f64::consts::FRAC_PI_2),
            top_k: 3,
            min_score: 0.3,
            drift_min_score: 0.005,
            drift_path_cut: 5.0,
            max_verify: 8,
            prior_gate: true,
            proximity: true,
            drift_probe: true,
            probe_every: 48,
            queue_capacity: 4,
            workers: 1,
            jump_factor: 25.0,
            block_len: 2048,
        }
    }
}

impl OnlineConfig {
    /// Most matching threads the command line and the C ABI take (beyond
    /// the cores they gain nothing).
    pub const MAX_WORKERS: usize = 64;

    /// Growth of the proximity probe's radius per unit of path between the
    /// two parts: the drift prior's position rate with [`Self::drift_probe`]
    /// (else 0: the consistent map's probe only).
    pub fn drift_radius(&self) -> f64 {
        match self.drift_probe {
            true => self.pipeline.drift_prior.map_or(0.0, |p| p.position),
            false => 0.0,
        }
    }
}
