//! The ORB verifier: keeps the features of recent keyframes within a memory
//! cap and decides whether two keyframes see the same place.
//!
//! Keyframes are reduced to features on arrival ([`OrbVerifier::add_keyframe`]);
//! the store is a least-recently-used cache bounded in bytes, so a long run
//! never grows without bound: the keyframes used longest ago are dropped first,
//! and a candidate naming a dropped keyframe is rejected with that reason.

use std::collections::{BTreeMap, HashMap};

use super::camera::CameraModel;
use super::features::{FeatureExtractor, GrayImage, KeyframeFeatures, OrbParams};
use super::matching::{DescriptorMatcher, MatchParams};
use super::relative_pose::{
    estimate_relative_pose, Correspondence, PoseOutcome, PoseParams, RelativePose,
};

/// Default memory cap for stored features: 256 MiB, about 2 500 keyframes of 1 000 ORB features.
pub const DEFAULT_MEMORY_CAP: usize = 256 << 20;

/// Bytes counted per stored keyframe on top of its features (map and LRU entries).
const ENTRY_OVERHEAD: usize = 64;

/// All settings of the verifier.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VerifierParams {
    /// ORB detector settings.
    pub orb: OrbParams,
    /// Descriptor matching settings.
    pub matching: MatchParams,
    /// Relative-pose acceptance thresholds.
    pub pose: PoseParams,
    /// Most bytes of features kept (see [`KeyframeFeatures::memory_bytes`]).
    pub memory_cap: usize,
}

impl Default for VerifierParams {
    fn default() -> Self {
        VerifierParams {
            orb: OrbParams::default(),
            matching: MatchParams::default(),
            pose: PoseParams::default(),
            memory_cap: DEFAULT_MEMORY_CAP,
        }
    }
}

/// The answer for one candidate pair.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// Query keyframe id (camera a).
    pub query_id: u64,
    /// Match keyframe id (camera b).
    pub match_id: u64,
    /// Accepted pose `match_T_query` when confirmed.
    pub pose: Option<RelativePose>,
    /// Descriptor matches that passed the ratio and mutual tests.
    pub matches: usize,
    /// Inliers of the chosen (or best rejected) model.
    pub inliers: usize,
    /// Human-readable reason (why rejected, or which model confirmed).
    pub reason: String,
}

/// A verdict flattened to plain numbers, as message payloads carry it.
#[derive(Debug, Clone, PartialEq)]
pub struct VerdictParts {
    /// Confirmed (true) or rejected.
    pub confirmed: bool,
    /// `match_R_query`, row-major (identity when rejected).
    pub rotation: [f64; 9],
    /// Unit translation `match_t_query`; zero when rejected or rotation only.
    pub translation: [f64; 3],
    /// Inlier count.
    pub inliers: u32,
    /// Reason text.
    pub reason: String,
}

impl Verdict {
    /// True when the images confirm the candidate.
    pub fn confirmed(&self) -> bool {
        self.pose.is_some()
    }

    /// The verdict as plain numbers for a message payload.
    pub fn parts(&self) -> VerdictParts {
        let (rotation, translation) = match &self.pose {
            Some(p) => {
                let m = p.b_R_a.matrix();
                let mut r = [0.0; 9];
                for (k, v) in r.iter_mut().enumerate() {
                    *v = m[(k / 3, k % 3)];
                }
                (r, [p.b_t_a.x, p.b_t_a.y, p.b_t_a.z])
            }
            None => ([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], [0.0; 3]),
        };
        VerdictParts {
            confirmed: self.confirmed(),
            rotation,
            translation,
            inliers: self.inliers.min(u32::MAX as usize) as u32,
            reason: self.reason.clone(),
        }
    }
}

struct Entry {
    features: KeyframeFeatures,
    last_used: u64,
    bytes: usize,
}

/// Visual verifier: ORB features per keyframe, matching and relative pose.
pub struct OrbVerifier {
    params: VerifierParams,
    extractor: FeatureExtractor,
    matcher: DescriptorMatcher,
    store: HashMap<u64, Entry>,
    lru: BTreeMap<u64, u64>,
    clock: u64,
    bytes: usize,
    /// Keyframes evicted under the memory cap since [`OrbVerifier::take_evicted`].
    evicted: u64,
}

impl OrbVerifier {
    /// Creates a verifier with the given settings.
    pub fn new(params: VerifierParams) -> Result<Self, String> {
        Ok(OrbVerifier {
            params,
            extractor: FeatureExtractor::new(params.orb)?,
            matcher: DescriptorMatcher::new(params.matching)?,
            store: HashMap::new(),
            lru: BTreeMap::new(),
            clock: 0,
            bytes: 0,
            evicted: 0,
        })
    }

    /// Settings in use.
    pub fn params(&self) -> &VerifierParams {
        &self.params
    }

    /// Extracts the features of a keyframe and stores them (replacing any
    /// keyframe with the same id), evicting the least recently used keyframes
    /// beyond the memory cap.
    pub fn add_keyframe(
        &mut self,
        id: u64,
        camera: CameraModel,
        image: GrayImage<'_>,
    ) -> Result<(), String> {
        let features = self.extractor.extract(id, camera, image)?;
        self.insert_features(features)
    }

    /// Stores already-extracted features (see [`OrbVerifier::add_keyframe`]).
    pub fn insert_features(&mut self, features: KeyframeFeatures) -> Result<(), String> {
        let id = features.id;
        let bytes = features.memory_bytes() + ENTRY_OVERHEAD;
        if bytes > self.params.memory_cap {
            return Err(format!(
                "keyframe {id}: features take {bytes} bytes, more than the cap of {} bytes",
                self.params.memory_cap
            ));
        }
        self.remove(id);
        while self.bytes + bytes > self.params.memory_cap {
            let Some((_, oldest)) = self.lru.pop_first() else {
                break;
            };
            if let Some(entry) = self.store.remove(&oldest) {
                self.bytes -= entry.bytes;
                self.evicted += 1;
            }
        }
        self.clock += 1;
        self.lru.insert(self.clock, id);
        self.store.insert(
            id,
            Entry {
                features,
                last_used: self.clock,
                bytes,
            },
        );
        self.bytes += bytes;
        Ok(())
    }

    /// Keyframes evicted under the memory cap since the last call.
    pub fn take_evicted(&mut self) -> u64 {
        std::mem::take(&mut self.evicted)
    }

    /// Forgets a keyframe; true when it was stored.
    pub fn remove(&mut self, id: u64) -> bool {
        match self.store.remove(&id) {
            Some(entry) => {
                self.lru.remove(&entry.last_used);
                self.bytes -= entry.bytes;
                true
            }
            None => false,
        }
    }

    /// Features of a stored keyframe.
    pub fn features(&self, id: u64) -> Option<&KeyframeFeatures> {
        self.store.get(&id).map(|e| &e.features)
    }

    /// Number of stored keyframes.
    pub fn len(&self) -> usize {
        self.store.len()
    }

    /// True when no keyframe is stored.
    pub fn is_empty(&self) -> bool {
        self.store.is_empty()
    }

    /// Bytes held by stored features (never above the cap).
    pub fn memory_bytes(&self) -> usize {
        self.bytes
    }

    fn touch(&mut self, id: u64) {
        if let Some(entry) = self.store.get_mut(&id) {
            self.lru.remove(&entry.last_used);
            self.clock += 1;
            entry.last_used = self.clock;
            self.lru.insert(self.clock, id);
        }
    }

    /// Decides whether keyframes `query_id` and `match_id` show the same place;
    /// the pose, when confirmed, is `match_T_query`.
    pub fn verify(&mut self, query_id: u64, match_id: u64) -> Verdict {
        let mut verdict = Verdict {
            query_id,
            match_id,
            pose: None,
            matches: 0,
            inliers: 0,
            reason: String::new(),
        };
        for id in [query_id, match_id] {
            if !self.store.contains_key(&id) {
                verdict.reason = format!("keyframe {id} unknown (never received or evicted)");
                return verdict;
            }
            self.touch(id);
        }
        let (a, b) = (
            &self.store[&query_id].features,
            &self.store[&match_id].features,
        );
        let pairs = match self.matcher.match_features(a, b) {
            Ok(p) => p,
            Err(e) => {
                verdict.reason = e;
                return verdict;
            }
        };
        verdict.matches = pairs.len();
        let corr: Vec<Correspondence> = pairs
            .iter()
            .map(|&(i, j)| Correspondence {
                a: a.bearings[i],
                b: b.bearings[j],
                sigma: a.sigmas[i].hypot(b.sigmas[j]),
            })
            .collect();
        let seed = query_id.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ match_id;
        match estimate_relative_pose(&corr, &self.params.pose, seed) {
            PoseOutcome::Accepted(pose) => {
                verdict.inliers = pose.inliers.len();
                verdict.reason = format!(
                    "{:?} pose, {} inliers of {} matches",
                    pose.kind,
                    pose.inliers.len(),
                    pairs.len()
                );
                verdict.pose = Some(pose);
            }
            PoseOutcome::Rejected { reason, inliers } => {
                verdict.inliers = inliers;
                verdict.reason = reason;
            }
        }
        verdict
    }
}
