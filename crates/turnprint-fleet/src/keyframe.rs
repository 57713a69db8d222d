//! Keyframes shared between robots for visual verification: a robot serves
//! the image and camera of any of its keyframes under
//! `turnprint/<fleet>/<robot>/keyframes/<pose>` (Zenoh queryable, answered
//! on request only, so no image crosses the network unless a cross-robot
//! candidate needs it), and a robot that finds a candidate against another
//! fetches that robot's keyframe and verifies the pair with its own.
//!
//! Layout (payload kind 2 of [`crate::payload`], little-endian):
//!
//! ```text
//! "TPFL"  u16 version  u8 kind = 2  u8 flags = 0
//! u64 pose  f64 t
//! u32 camera kind  u32 width  u32 height  f64 x 12 camera parameters
//! u32 n_bytes  n_bytes x u8 (grey image, row-major, width x height)
//! ```

use crate::payload::{garbage, header, Reader, Refusal, MAGIC, VERSION};

/// Largest image side a keyframe may have (pixels): far above any camera a
/// robot carries, so that a forged size is refused before it is believed.
pub const MAX_SIDE: u32 = 8192;

/// One keyframe: the grey image a robot saw at one of its poses, and the
/// camera that saw it.
#[derive(Debug, Clone, PartialEq)]
pub struct Keyframe {
    /// The robot's pose index of the keyframe.
    pub pose: u64,
    /// Its time stamp (the pose index where the path has none).
    pub t: f64,
    /// Camera model code (`turnprint_ipc::payload::camera_kind`).
    pub camera_kind: u32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Camera model parameters, in the order of the model's code.
    pub params: [f64; 12],
    /// Grey image, row-major, `width * height` bytes.
    pub image: Vec<u8>,
}

impl Keyframe {
    /// The payload.
    pub fn encode(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(48 + 12 * 8 + self.image.len());
        b.extend_from_slice(MAGIC);
        b.extend_from_slice(&VERSION.to_le_bytes());
        b.push(2);
        b.push(0);
        b.extend_from_slice(&self.pose.to_le_bytes());
        b.extend_from_slice(&self.t.to_le_bytes());
        for v in [self.camera_kind, self.width, self.height] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in self.params {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&(self.image.len() as u32).to_le_bytes());
        b.extend_from_slice(&self.image);
        b
    }

    /// Reads a keyframe's payload, refusing anything this build cannot
    /// trust: a newer version as such, anything else unknown, cut short,
    /// non-finite or of an image that is not `width * height` as garbage.
    pub fn decode(bytes: &[u8]) -> Result<Keyframe, Refusal> {
        let mut r = Reader { b: bytes, at: 0 };
        header(&mut r)?;
        if r.u8()? != 2 {
            return Err(garbage("not a keyframe"));
        }
        if r.u8()? != 0 {
            return Err(garbage("unknown flags"));
        }
        let (pose, t) = (r.u64()?, r.f64()?);
        let (camera_kind, width, height) = (r.u32()?, r.u32()?, r.u32()?);
        let mut params = [0.0; 12];
        for p in &mut params {
            *p = r.f64()?;
        }
        if !t.is_finite() || !params.iter().all(|p| p.is_finite()) {
            return Err(garbage("a keyframe field is not finite"));
        }
        if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
            return Err(garbage("a keyframe size out of range"));
        }
        let n = r.count(1)?;
        if n != width as usize * height as usize {
            return Err(garbage("an image that is not width x height"));
        }
        let image = r.take(n)?.to_vec();
        if r.at != bytes.len() {
            return Err(garbage("bytes after the payload"));
        }
        Ok(Keyframe {
            pose,
            t,
            camera_kind,
            width,
            height,
            params,
            image,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keyframe() -> Keyframe {
        Keyframe {
            pose: 40,
            t: 12.5,
            camera_kind: 1,
            width: 4,
            height: 3,
            params: [2.0, 2.0, 1.5, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            image: (0..12).collect(),
        }
    }

    #[test]
    fn a_keyframe_reads_back_as_written() {
        let k = keyframe();
        assert_eq!(Keyframe::decode(&k.encode()), Ok(k));
    }

    #[test]
    fn every_cut_a_forged_size_and_a_newer_version_are_refused() {
        let bytes = keyframe().encode();
        for n in 0..bytes.len() {
            assert!(matches!(
                Keyframe::decode(&bytes[..n]),
                Err(Refusal::Garbage(_))
            ));
        }
        let mut newer = bytes.clone();
        newer[4..6].copy_from_slice(&(VERSION + 1).to_le_bytes());
        assert_eq!(Keyframe::decode(&newer), Err(Refusal::Version(VERSION + 1)));
        // Width 4 -> 5: the image no longer fills it.
        let mut wider = bytes.clone();
        wider[28..32].copy_from_slice(&5u32.to_le_bytes());
        assert!(matches!(Keyframe::decode(&wider), Err(Refusal::Garbage(_))));
        // A keyframe is never taken for a data payload.
        assert!(matches!(
            crate::payload::decode(&bytes),
            Err(Refusal::Garbage(_))
        ));
        let mut nan = bytes;
        nan[16..24].copy_from_slice(&f64::NAN.to_le_bytes());
        assert!(matches!(Keyframe::decode(&nan), Err(Refusal::Garbage(_))));
    }
}
