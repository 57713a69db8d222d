//! ORB features of one keyframe, with each keypoint lifted to a bearing vector.
//!
//! A keyframe is reduced to its features as soon as it arrives; the image is
//! not kept. Each keypoint carries its unit bearing (through the keyframe's own
//! camera model) and its angular uncertainty, so matching and geometry never
//! look at pixels again and mixed cameras compare like for like.

use nalgebra::{Vector2, Vector3};
use opencv::core::{KeyPoint, Mat, Ptr, Vector};
use opencv::features2d::{ORB_ScoreType, ORB};
use opencv::prelude::*;

use super::camera::CameraModel;

/// Bytes of one ORB descriptor (256 bits).
pub const DESCRIPTOR_BYTES: usize = 32;

/// Settings of the ORB detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrbParams {
    /// Most keypoints kept per keyframe.
    pub max_features: i32,
    /// Ratio between pyramid levels.
    pub scale_factor: f32,
    /// Number of pyramid levels.
    pub levels: i32,
    /// FAST threshold (grey levels); low so that soft textures still give corners.
    pub fast_threshold: i32,
    /// Cameras coarser than this at the image centre (pixels per radian) are
    /// upsampled into extra pyramid levels, so that a wide-angle keyframe also
    /// has features at the angular scales of a narrow camera's fine levels.
    pub min_pixels_per_radian: f64,
    /// Most levels added by upsampling.
    pub max_upsampled_levels: i32,
}

impl Default for OrbParams {
    fn default() -> Self {
        OrbParams {
            max_features: 1000,
            scale_factor: 1.2,
            levels: 8,
            fast_threshold: 12,
            min_pixels_per_radian: 300.0,
            max_upsampled_levels: 4,
        }
    }
}

/// One detected keypoint: where it is in the image and at which pyramid level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Keypoint {
    /// Pixel position (u, v).
    pub pixel: Vector2<f32>,
    /// Pyramid level the keypoint was found at.
    pub octave: i32,
    /// Orientation in degrees, as ORB reports it.
    pub angle: f32,
}

/// The features of one keyframe: everything the verifier keeps of it.
#[derive(Debug, Clone)]
pub struct KeyframeFeatures {
    /// Keyframe id given by the caller.
    pub id: u64,
    /// Camera model of the keyframe.
    pub camera: CameraModel,
    /// Keypoints, in the same order as `descriptors` rows and `bearings`.
    pub keypoints: Vec<Keypoint>,
    /// ORB descriptors, `DESCRIPTOR_BYTES` per keypoint, row after row.
    pub descriptors: Vec<u8>,
    /// Unit bearing of each keypoint in the camera frame.
    pub bearings: Vec<Vector3<f64>>,
    /// Angular size (radians) of one pixel at the keypoint's pyramid level
    /// (below one source pixel on upsampled levels): the unit of geometric
    /// error for that keypoint.
    pub sigmas: Vec<f64>,
}

impl KeyframeFeatures {
    /// Number of keypoints.
    pub fn len(&self) -> usize {
        self.keypoints.len()
    }

    /// True when no keypoint was found.
    pub fn is_empty(&self) -> bool {
        self.keypoints.is_empty()
    }

    /// Heap and inline bytes held by these features (what the memory cap counts).
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.keypoints.capacity() * std::mem::size_of::<Keypoint>()
            + self.descriptors.capacity()
            + self.bearings.capacity() * std::mem::size_of::<Vector3<f64>>()
            + self.sigmas.capacity() * std::mem::size_of::<f64>()
    }

    /// The descriptors as an OpenCV matrix (one row per keypoint, no copy).
    pub fn descriptor_mat(&self) -> Result<opencv::boxed_ref::BoxedRef<'_, Mat>, String> {
        Mat::new_rows_cols_with_data(
            self.len() as i32,
            DESCRIPTOR_BYTES as i32,
            &self.descriptors,
        )
        .map_err(|e| format!("descriptor matrix: {e}"))
    }
}

/// A grey 8-bit image borrowed from the caller, rows `stride` bytes apart.
#[derive(Debug, Clone, Copy)]
pub struct GrayImage<'a> {
    /// Pixel bytes.
    pub data: &'a [u8],
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Bytes from one row to the next (>= width).
    pub stride: u32,
}

/// Turns grey images into [`KeyframeFeatures`] with OpenCV's ORB.
pub struct FeatureExtractor {
    params: OrbParams,
    /// ORB detectors by number of upsampled levels.
    orbs: Vec<Option<Ptr<ORB>>>,
}

impl FeatureExtractor {
    /// Creates the extractor (detectors are made on first use).
    pub fn new(params: OrbParams) -> Result<Self, String> {
        if params.max_features < 1 || params.levels < 1 || params.scale_factor <= 1.0 {
            return Err(format!("bad ORB settings {params:?}"));
        }
        let mut extractor = FeatureExtractor {
            params,
            orbs: (0..=params.max_upsampled_levels.max(0))
                .map(|_| None)
                .collect(),
        };
        extractor.orb(0)?;
        Ok(extractor)
    }

    /// The detector whose pyramid starts `upsampled` levels above the image.
    fn orb(&mut self, upsampled: i32) -> Result<&mut Ptr<ORB>, String> {
        let p = self.params;
        let slot = &mut self.orbs[upsampled as usize];
        if slot.is_none() {
            // The upsampled levels get their share of features on top of the usual budget.
            let features =
                (p.max_features as f64 * (p.scale_factor as f64).powi(upsampled)).round() as i32;
            let orb = ORB::create(
                features,
                p.scale_factor,
                p.levels + upsampled,
                31,
                upsampled,
                2,
                ORB_ScoreType::HARRIS_SCORE,
                31,
                p.fast_threshold,
            )
            .map_err(|e| format!("ORB::create: {e}"))?;
            *slot = Some(orb);
        }
        Ok(slot.as_mut().expect("created above"))
    }

    /// Levels to upsample for `camera`: enough to reach `min_pixels_per_radian` at the centre.
    fn upsampled_levels(&self, camera: &CameraModel, width: usize, height: usize) -> i32 {
        let centre = Vector2::new(0.5 * (width as f64 - 1.0), 0.5 * (height as f64 - 1.0));
        let Some(angle) = camera.pixel_angle(&centre) else {
            return 0;
        };
        let ratio = self.params.min_pixels_per_radian * angle;
        if ratio <= 1.0 {
            return 0;
        }
        ((ratio.ln() / (self.params.scale_factor as f64).ln()).ceil() as i32)
            .clamp(0, self.params.max_upsampled_levels.max(0))
    }

    /// Settings in use.
    pub fn params(&self) -> OrbParams {
        self.params
    }

    /// Detects ORB features in `image` and lifts them to bearings with `camera`.
    /// Keypoints whose pixel has no ray in the model are dropped.
    pub fn extract(
        &mut self,
        id: u64,
        camera: CameraModel,
        image: GrayImage<'_>,
    ) -> Result<KeyframeFeatures, String> {
        let (w, h, stride) = (
            image.width as usize,
            image.height as usize,
            image.stride as usize,
        );
        if w == 0 || h == 0 {
            return Err(format!("keyframe {id}: empty image {w}x{h}"));
        }
        if stride < w {
            return Err(format!(
                "keyframe {id}: stride {stride} smaller than width {w}"
            ));
        }
        let needed = stride * (h - 1) + w;
        if image.data.len() < needed {
            return Err(format!(
                "keyframe {id}: {} bytes for a {w}x{h} image with stride {stride} (need {needed})",
                image.data.len()
            ));
        }
        camera
            .validate()
            .map_err(|e| format!("keyframe {id}: {e}"))?;
        let packed;
        let pixels: &[u8] = if stride == w {
            &image.data[..w * h]
        } else {
            packed = (0..h)
                .flat_map(|r| image.data[r * stride..r * stride + w].iter().copied())
                .collect::<Vec<u8>>();
            &packed
        };
        let mat = Mat::new_rows_cols_with_data(h as i32, w as i32, pixels)
            .map_err(|e| format!("keyframe {id}: image matrix: {e}"))?;
        let mut keypoints: Vector<KeyPoint> = Vector::new();
        let mut descriptors = Mat::default();
        let upsampled = self.upsampled_levels(&camera, w, h);
        self.orb(upsampled)?
            .detect_and_compute(
                &mat,
                &opencv::core::no_array(),
                &mut keypoints,
                &mut descriptors,
                false,
            )
            .map_err(|e| format!("keyframe {id}: ORB: {e}"))?;
        let mut out = KeyframeFeatures {
            id,
            camera,
            keypoints: Vec::with_capacity(keypoints.len()),
            descriptors: Vec::with_capacity(keypoints.len() * DESCRIPTOR_BYTES),
            bearings: Vec::with_capacity(keypoints.len()),
            sigmas: Vec::with_capacity(keypoints.len()),
        };
        if keypoints.is_empty() {
            return Ok(out);
        }
        let bytes = descriptors
            .data_bytes()
            .map_err(|e| format!("keyframe {id}: descriptors: {e}"))?;
        for (i, kp) in keypoints.iter().enumerate() {
            let pt = kp.pt();
            let pixel = Vector2::new(pt.x as f64, pt.y as f64);
            let (Some(bearing), Some(angle)) =
                (camera.unproject(&pixel), camera.pixel_angle(&pixel))
            else {
                continue;
            };
            // Keypoints are in source pixels; level `upsampled` is the source resolution.
            let level_scale = (self.params.scale_factor as f64).powi(kp.octave() - upsampled);
            out.keypoints.push(Keypoint {
                pixel: Vector2::new(pt.x, pt.y),
                octave: kp.octave(),
                angle: kp.angle(),
            });
            out.descriptors
                .extend_from_slice(&bytes[i * DESCRIPTOR_BYTES..(i + 1) * DESCRIPTOR_BYTES]);
            out.bearings.push(bearing.into_inner());
            out.sigmas.push(angle * level_scale);
        }
        out.keypoints.shrink_to_fit();
        out.descriptors.shrink_to_fit();
        out.bearings.shrink_to_fit();
        out.sigmas.shrink_to_fit();
        Ok(out)
    }
}
