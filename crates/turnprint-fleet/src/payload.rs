//! The wire form of a robot's finalised samples: one [`Chunk`] per
//! hand-over of the detector (usually one new segment), little-endian
//! binary with a magic, an explicit version and lengths that are checked
//! against the bytes before anything is read.
//!
//! Layout of version 2 (all little-endian):
//!
//! ```text
//! "TPFL"  u16 version  u8 kind  u8 flags
//! kind 1, a status (sent every second: what a robot has published, and
//! the first chunk it still serves to a robot catching up):
//! u64 epoch  u32 chunks  u32 first
//! kind 0, a chunk (flags bit 0: the robot's stream ended):
//! u64 epoch  u32 seq  u32 poses
//! plane: f64 x 3 origin, f64 x 9 world_R_plane (row-major)
//! f64 step  f64 bandwidth  f64 dk
//! u32 grid_end (track samples so far)  u32 n_kept
//!   n_kept x { u32 index, f32 x, f32 y, f64 s, f32 curvature, f32 pose }
//! u32 sig0  u32 n_sig   n_sig x { f32 value, f64 grid }
//! u32 n_bounds          n_bounds x u32
//! kind 2, a keyframe, served on request only: see [`crate::keyframe`]
//! ```
//!
//! The track is decimated (one sample in [`DECIMATION`], and each chunk's
//! last): the receiver fills the samples in between linearly. The
//! signature samples and the boundaries go whole: they are what is
//! matched.

use nalgebra::{Matrix3, Vector3};
use turnprint::geometry::Plane;

/// The version this build writes and reads. A payload of a newer version is
/// refused (counted as `version`), not guessed at.
pub const VERSION: u16 = 2;

/// First bytes of every payload.
pub(crate) const MAGIC: &[u8; 4] = b"TPFL";

/// One track sample in this many is sent. The track is a smoothing spline
/// sampled at about half the typical step, with a bandwidth of several
/// steps: linear interpolation over 4 samples (2 steps) stays far inside
/// the smoothing (a few thousandths of a step on a turn of radius 10
/// steps), and the bytes of the track drop four-fold.
pub const DECIMATION: usize = 4;

/// Bytes of one kept track sample on the wire.
const KEPT_BYTES: usize = 4 + 4 + 4 + 8 + 4 + 4;
/// Bytes of one signature sample on the wire.
const SIG_BYTES: usize = 4 + 8;

/// Why a payload was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// Not a payload of ours, cut short, inconsistent or non-finite.
    #[error("garbage: {0}")]
    Garbage(String),
    /// A payload version this build does not know (newer).
    #[error("payload version {0}, this build reads {VERSION}")]
    Version(u16),
}

/// The frame a robot's history lives in (its detector's track parameters).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameInfo {
    /// The plane of its 2D track.
    pub plane: Plane,
    /// Track grid step.
    pub step: f64,
    /// Smoothing bandwidth.
    pub bandwidth: f64,
    /// Signature step of turning (radians).
    pub dk: f64,
}

/// One kept track sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeptSample {
    /// Index of the sample in the robot's track.
    pub index: u32,
    /// Position in the plane.
    pub xy: [f32; 2],
    /// Arc length.
    pub s: f64,
    /// Curvature.
    pub curvature: f32,
    /// Fractional pose index.
    pub pose: f32,
}

/// One hand-over of a robot's finalised samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Chunk {
    /// The robot process's session: a restarted robot starts a new one.
    pub epoch: u64,
    /// Number of this chunk in its session, from 0.
    pub seq: u32,
    /// The robot's stream has ended: no chunk follows.
    pub last: bool,
    /// Poses the robot had pushed.
    pub poses: u32,
    /// The robot's frame.
    pub frame: FrameInfo,
    /// Track samples of the robot so far, after this chunk.
    pub grid_end: u32,
    /// The kept track samples of this chunk, increasing; the last is
    /// sample `grid_end - 1` when the chunk has any.
    pub kept: Vec<KeptSample>,
    /// Index of the first signature sample of this chunk.
    pub sig0: u32,
    /// Signature samples: value and fractional track index.
    pub sig: Vec<(f32, f64)>,
    /// New segment boundaries (signature indices).
    pub bounds: Vec<u32>,
}

/// A payload: a chunk of samples or a robot's status.
#[derive(Debug, Clone, PartialEq)]
pub enum Message {
    /// Finalised samples.
    Chunk(Box<Chunk>),
    /// What the robot has published: a receiver that holds fewer chunks
    /// of that session asks for its history.
    Status {
        /// The robot's session.
        epoch: u64,
        /// Chunks published in it.
        chunks: u32,
        /// The first chunk it still serves (the older ones were dropped
        /// from its bounded store): a receiver missing an older one starts
        /// the robot's history here.
        first: u32,
    },
}

/// The payload of a status.
pub fn encode_status(epoch: u64, chunks: u32, first: u32) -> Vec<u8> {
    let mut b = Vec::with_capacity(24);
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&VERSION.to_le_bytes());
    b.push(1);
    b.push(0);
    b.extend_from_slice(&epoch.to_le_bytes());
    b.extend_from_slice(&chunks.to_le_bytes());
    b.extend_from_slice(&first.to_le_bytes());
    b
}

/// Reads the magic and the version every payload starts with: a newer
/// version is refused as such, anything else unknown as garbage.
pub(crate) fn header(r: &mut Reader) -> Result<(), Refusal> {
    if r.take(4)? != MAGIC {
        return Err(garbage("no turnprint fleet magic"));
    }
    let version = r.u16()?;
    if version > VERSION {
        return Err(Refusal::Version(version));
    }
    if version != VERSION {
        return Err(garbage(&format!("unknown payload version {version}")));
    }
    Ok(())
}

/// Reads a payload, refusing anything this build cannot trust.
pub fn decode(bytes: &[u8]) -> Result<Message, Refusal> {
    let mut r = Reader { b: bytes, at: 0 };
    header(&mut r)?;
    match r.u8()? {
        0 => Chunk::decode(bytes).map(|c| Message::Chunk(Box::new(c))),
        // Keyframes are only served on request (`crate::keyframe`).
        2 => Err(garbage("a keyframe is no data payload")),
        1 => {
            if r.u8()? != 0 {
                return Err(garbage("unknown flags"));
            }
            let (epoch, chunks, first) = (r.u64()?, r.u32()?, r.u32()?);
            if r.at != bytes.len() {
                return Err(garbage("bytes after the payload"));
            }
            if first > chunks {
                return Err(garbage("a first chunk served past those published"));
            }
            Ok(Message::Status {
                epoch,
                chunks,
                first,
            })
        }
        _ => Err(garbage("unknown payload kind")),
    }
}

impl Chunk {
    /// The payload.
    pub fn encode(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(
            160 + self.kept.len() * KEPT_BYTES + self.sig.len() * SIG_BYTES + self.bounds.len() * 4,
        );
        b.extend_from_slice(MAGIC);
        b.extend_from_slice(&VERSION.to_le_bytes());
        b.push(0);
        b.push(u8::from(self.last));
        b.extend_from_slice(&self.epoch.to_le_bytes());
        b.extend_from_slice(&self.seq.to_le_bytes());
        b.extend_from_slice(&self.poses.to_le_bytes());
        let f = &self.frame;
        for v in f.plane.origin.iter() {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for r in 0..3 {
            for c in 0..3 {
                b.extend_from_slice(&f.plane.world_R_plane[(r, c)].to_le_bytes());
            }
        }
        for v in [f.step, f.bandwidth, f.dk] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&self.grid_end.to_le_bytes());
        b.extend_from_slice(&(self.kept.len() as u32).to_le_bytes());
        for k in &self.kept {
            b.extend_from_slice(&k.index.to_le_bytes());
            b.extend_from_slice(&k.xy[0].to_le_bytes());
            b.extend_from_slice(&k.xy[1].to_le_bytes());
            b.extend_from_slice(&k.s.to_le_bytes());
            b.extend_from_slice(&k.curvature.to_le_bytes());
            b.extend_from_slice(&k.pose.to_le_bytes());
        }
        b.extend_from_slice(&self.sig0.to_le_bytes());
        b.extend_from_slice(&(self.sig.len() as u32).to_le_bytes());
        for (v, g) in &self.sig {
            b.extend_from_slice(&v.to_le_bytes());
            b.extend_from_slice(&g.to_le_bytes());
        }
        b.extend_from_slice(&(self.bounds.len() as u32).to_le_bytes());
        for v in &self.bounds {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b
    }

    /// Reads a chunk's payload, refusing anything this build cannot trust.
    pub fn decode(bytes: &[u8]) -> Result<Chunk, Refusal> {
        let mut r = Reader { b: bytes, at: 0 };
        header(&mut r)?;
        if r.u8()? != 0 {
            return Err(garbage("unknown payload kind"));
        }
        let flags = r.u8()?;
        if flags > 1 {
            return Err(garbage("unknown flags"));
        }
        let epoch = r.u64()?;
        let seq = r.u32()?;
        let poses = r.u32()?;
        let origin = Vector3::new(r.f64()?, r.f64()?, r.f64()?);
        let mut m = Matrix3::zeros();
        for row in 0..3 {
            for col in 0..3 {
                m[(row, col)] = r.f64()?;
            }
        }
        let frame = FrameInfo {
            plane: Plane {
                origin,
                world_R_plane: m,
            },
            step: r.f64()?,
            bandwidth: r.f64()?,
            dk: r.f64()?,
        };
        let orthonormal = (m.transpose() * m - Matrix3::identity()).abs().max() < 1e-6;
        if !origin.iter().all(|v| v.is_finite()) || !orthonormal {
            return Err(garbage("the plane is not a frame"));
        }
        for v in [frame.step, frame.bandwidth, frame.dk] {
            if !(v.is_finite() && v > 0.0) {
                return Err(garbage("a track parameter is not positive"));
            }
        }
        let grid_end = r.u32()?;
        let n_kept = r.count(KEPT_BYTES)?;
        let mut kept = Vec::with_capacity(n_kept);
        for _ in 0..n_kept {
            let k = KeptSample {
                index: r.u32()?,
                xy: [r.f32()?, r.f32()?],
                s: r.f64()?,
                curvature: r.f32()?,
                pose: r.f32()?,
            };
            let finite =
                k.xy.iter()
                    .chain([&k.curvature, &k.pose])
                    .all(|v| v.is_finite())
                    && k.s.is_finite();
            if !finite || k.pose < 0.0 {
                return Err(garbage("a track sample is not finite"));
            }
            if kept
                .last()
                .is_some_and(|p: &KeptSample| p.index >= k.index || p.s > k.s || p.pose > k.pose)
            {
                return Err(garbage("track samples do not increase"));
            }
            kept.push(k);
        }
        if kept.last().is_some_and(|k| k.index + 1 != grid_end) {
            return Err(garbage("the last track sample is not the last"));
        }
        let sig0 = r.u32()?;
        let n_sig = r.count(SIG_BYTES)?;
        let mut sig = Vec::with_capacity(n_sig);
        for _ in 0..n_sig {
            let (v, g) = (r.f32()?, r.f64()?);
            if !v.is_finite() || !g.is_finite() || g < 0.0 {
                return Err(garbage("a signature sample is not finite"));
            }
            if sig.last().is_some_and(|&(_, p): &(f32, f64)| p > g) {
                return Err(garbage("signature samples do not increase"));
            }
            sig.push((v, g));
        }
        let n_bounds = r.count(4)?;
        let mut bounds = Vec::with_capacity(n_bounds);
        for _ in 0..n_bounds {
            bounds.push(r.u32()?);
        }
        if bounds.windows(2).any(|w| w[0] >= w[1]) {
            return Err(garbage("boundaries do not increase"));
        }
        if r.at != bytes.len() {
            return Err(garbage("bytes after the payload"));
        }
        Ok(Chunk {
            epoch,
            seq,
            last: flags & 1 == 1,
            poses,
            frame,
            grid_end,
            kept,
            sig0,
            sig,
            bounds,
        })
    }
}

pub(crate) fn garbage(why: &str) -> Refusal {
    Refusal::Garbage(why.to_string())
}

/// Reads little-endian values, never past the end.
pub(crate) struct Reader<'a> {
    pub(crate) b: &'a [u8],
    pub(crate) at: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn take(&mut self, n: usize) -> Result<&'a [u8], Refusal> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.b.len());
        let end = end.ok_or_else(|| garbage("cut short"))?;
        let s = &self.b[self.at..end];
        self.at = end;
        Ok(s)
    }
    pub(crate) fn array<const N: usize>(&mut self) -> Result<[u8; N], Refusal> {
        let mut a = [0; N];
        a.copy_from_slice(self.take(N)?);
        Ok(a)
    }
    pub(crate) fn u8(&mut self) -> Result<u8, Refusal> {
        Ok(self.take(1)?[0])
    }
    pub(crate) fn u16(&mut self) -> Result<u16, Refusal> {
        Ok(u16::from_le_bytes(self.array()?))
    }
    pub(crate) fn u32(&mut self) -> Result<u32, Refusal> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    pub(crate) fn u64(&mut self) -> Result<u64, Refusal> {
        Ok(u64::from_le_bytes(self.array()?))
    }
    pub(crate) fn f32(&mut self) -> Result<f32, Refusal> {
        Ok(f32::from_le_bytes(self.array()?))
    }
    pub(crate) fn f64(&mut self) -> Result<f64, Refusal> {
        Ok(f64::from_le_bytes(self.array()?))
    }
    /// A count of items of `size` bytes each, which must fit in what is
    /// left (a forged count never allocates).
    pub(crate) fn count(&mut self, size: usize) -> Result<usize, Refusal> {
        let n = self.u32()? as usize;
        if n.saturating_mul(size) > self.b.len() - self.at {
            return Err(garbage("a count beyond the payload"));
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chunk() -> Chunk {
        Chunk {
            epoch: 7,
            seq: 3,
            last: true,
            poses: 120,
            frame: FrameInfo {
                plane: Plane {
                    origin: Vector3::new(1.0, 2.0, 3.0),
                    world_R_plane: Matrix3::identity(),
                },
                step: 0.5,
                bandwidth: 2.0,
                dk: 0.02,
            },
            grid_end: 9,
            kept: vec![
                KeptSample {
                    index: 4,
                    xy: [1.0, 2.0],
                    s: 2.0,
                    curvature: 0.1,
                    pose: 2.0,
                },
                KeptSample {
                    index: 8,
                    xy: [3.0, 2.5],
                    s: 4.0,
                    curvature: 0.0,
                    pose: 4.0,
                },
            ],
            sig0: 11,
            sig: vec![(0.3, 4.5), (0.2, 6.0)],
            bounds: vec![11, 12],
        }
    }

    #[test]
    fn a_chunk_reads_back_as_written() {
        let c = chunk();
        assert_eq!(Chunk::decode(&c.encode()), Ok(c));
    }

    #[test]
    fn every_cut_and_a_newer_version_are_refused_with_their_reason() {
        let bytes = chunk().encode();
        for n in 0..bytes.len() {
            assert!(matches!(
                Chunk::decode(&bytes[..n]),
                Err(Refusal::Garbage(_))
            ));
        }
        let status = encode_status(9, 4, 2);
        assert_eq!(
            decode(&status),
            Ok(Message::Status {
                epoch: 9,
                chunks: 4,
                first: 2
            })
        );
        assert!(matches!(decode(&status[..23]), Err(Refusal::Garbage(_))));
        assert!(matches!(
            decode(&encode_status(9, 4, 5)),
            Err(Refusal::Garbage(_))
        ));
        let mut newer = bytes.clone();
        newer[4..6].copy_from_slice(&(VERSION + 1).to_le_bytes());
        assert_eq!(Chunk::decode(&newer), Err(Refusal::Version(VERSION + 1)));
        // A forged count must not allocate its length.
        let mut forged = bytes;
        let at = 4 + 2 + 2 + 8 + 4 + 4 + 12 * 8 + 3 * 8 + 4;
        forged[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(Chunk::decode(&forged), Err(Refusal::Garbage(_))));
    }
}
