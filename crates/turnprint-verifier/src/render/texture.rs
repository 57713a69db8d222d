//! Procedural textures of the rendered world: facades with windows and
//! posters, asphalt with patches, all seeded by world position so that every
//! place looks different and the same place always looks the same.
//!
//! Every texture takes a filter width `fw` (metres of surface covered by one
//! pixel) and returns the texture box-filtered over it, so distant surfaces
//! fade to their mean instead of aliasing into noise that would differ from
//! one viewpoint to the next.

/// SplitMix64 finaliser: a well-mixed 64-bit hash.
pub fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Hash of a seed and two integer coordinates.
pub fn hash2(seed: u64, i: i64, j: i64) -> u64 {
    mix(seed ^ mix((i as u64).wrapping_mul(0x1656_67B1) ^ mix(j as u64)))
}

/// Uniform value in [0, 1) from a hash.
pub fn unit(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

fn smooth(t: f64) -> f64 {
    t * t * (3.0 - 2.0 * t)
}

/// Value noise in [0, 1] with lattice spacing `scale` metres.
pub fn value_noise(seed: u64, x: f64, y: f64, scale: f64) -> f64 {
    let (gx, gy) = (x / scale, y / scale);
    let (ix, iy) = (gx.floor(), gy.floor());
    let (fx, fy) = (smooth(gx - ix), smooth(gy - iy));
    let (ix, iy) = (ix as i64, iy as i64);
    let v = |a: i64, b: i64| unit(hash2(seed, ix + a, iy + b));
    let top = v(0, 0) + (v(1, 0) - v(0, 0)) * fx;
    let bottom = v(0, 1) + (v(1, 1) - v(0, 1)) * fx;
    top + (bottom - top) * fy
}

/// Value noise whose contrast fades once a pixel covers half a lattice cell.
fn filtered_noise(seed: u64, x: f64, y: f64, scale: f64, fw: f64) -> f64 {
    let fade = (1.0 - fw / (0.5 * scale)).clamp(0.0, 1.0);
    0.5 + (value_noise(seed, x, y, scale) - 0.5) * fade
}

/// Integral over `(-∞, x]` of a periodic pulse that is 1 on `[lo, hi)` of each unit period.
fn pulse_integral(x: f64, lo: f64, hi: f64) -> f64 {
    x.floor() * (hi - lo) + (x - x.floor() - lo).clamp(0.0, hi - lo)
}

/// Fraction of the filter window `[x - w/2, x + w/2]` covered by the periodic pulse.
fn filtered_pulse(x: f64, lo: f64, hi: f64, w: f64) -> f64 {
    if w < 1e-6 {
        let f = x - x.floor();
        return if f >= lo && f < hi { 1.0 } else { 0.0 };
    }
    (pulse_integral(x + 0.5 * w, lo, hi) - pulse_integral(x - 0.5 * w, lo, hi)) / w
}

/// Style of one building, drawn from its seed.
#[derive(Debug, Clone, Copy)]
pub struct Facade {
    seed: u64,
    wall: f64,
    bay: f64,
    floor: f64,
    window_lo: f64,
    window_hi: f64,
    sill_lo: f64,
    sill_hi: f64,
}

impl Facade {
    /// The style of the building with `seed`.
    pub fn new(seed: u64) -> Self {
        let r = |k: u64| unit(mix(seed ^ k.wrapping_mul(0xA24B_AED4_963E_E407)));
        let width = 0.35 + 0.3 * r(4);
        let height = 0.4 + 0.3 * r(5);
        let x0 = 0.5 * (1.0 - width);
        let y0 = 0.25 + 0.2 * r(6) * (1.0 - height);
        Facade {
            seed,
            wall: 0.35 + 0.45 * r(1),
            bay: 1.8 + 2.2 * r(2),
            floor: 2.8 + 0.9 * r(3),
            window_lo: x0,
            window_hi: x0 + width,
            sill_lo: y0,
            sill_hi: y0 + height,
        }
    }

    /// Grey level in [0, 1] at `s` metres along the facade and `h` metres above its base.
    pub fn shade(&self, s: f64, h: f64, fw: f64) -> f64 {
        // Wall: stained plaster, large and medium blotches unique to the place.
        let mut wall = self.wall + 0.35 * (filtered_noise(self.seed ^ 1, s, h, 2.5, fw) - 0.5);
        wall += 0.2 * (filtered_noise(self.seed ^ 2, s, h, 0.7, fw) - 0.5);
        // Posters near the ground: random rectangles per 3 m of facade.
        let cell = (s / 3.0).floor();
        let hp = hash2(self.seed ^ 3, cell as i64, 0);
        if unit(hp) < 0.45 && h > 0.3 && h < 2.6 {
            let x0 = cell * 3.0 + 0.3 + 1.2 * unit(mix(hp ^ 1));
            let w = 0.6 + 1.0 * unit(mix(hp ^ 2));
            let y0 = 0.4 + 0.6 * unit(mix(hp ^ 3));
            let hgt = 0.5 + 1.0 * unit(mix(hp ^ 4));
            let cover_x =
                ((s - x0 + 0.5 * fw).min(w) - (s - x0 - 0.5 * fw).max(0.0)).max(0.0) / fw.max(1e-6);
            let cover_y = ((h - y0 + 0.5 * fw).min(hgt) - (h - y0 - 0.5 * fw).max(0.0)).max(0.0)
                / fw.max(1e-6);
            let cover = if fw < 1e-6 {
                f64::from(s >= x0 && s < x0 + w && h >= y0 && h < y0 + hgt)
            } else {
                (cover_x * cover_y).min(1.0)
            };
            let poster = 0.1 + 0.8 * filtered_noise(hp, s, h, 0.35, fw);
            wall += (poster - wall) * cover;
        }
        // Windows from the first floor up: a grid with one grey level per pane.
        if h > self.floor {
            let (u, v) = (s / self.bay, h / self.floor);
            let cover = filtered_pulse(u, self.window_lo, self.window_hi, fw / self.bay)
                * filtered_pulse(v, self.sill_lo, self.sill_hi, fw / self.floor);
            let pane = unit(hash2(self.seed ^ 4, u.floor() as i64, v.floor() as i64));
            let glass = if pane < 0.15 {
                0.85 + 0.1 * pane
            } else {
                0.05 + 0.35 * pane
            };
            // Distant windows average with their neighbours.
            let mean_glass = 0.27;
            let far = (fw / self.bay).clamp(0.0, 1.0);
            wall += ((glass * (1.0 - far) + mean_glass * far) - wall) * cover;
        }
        wall.clamp(0.0, 1.0)
    }
}

/// Grey level of the ground at world `(x, z)`: asphalt with patches and stains.
pub fn ground_shade(seed: u64, x: f64, z: f64, fw: f64) -> f64 {
    let mut g = 0.42 + 0.25 * (filtered_noise(seed ^ 11, x, z, 3.0, fw) - 0.5);
    g += 0.25 * (filtered_noise(seed ^ 12, x, z, 0.8, fw) - 0.5);
    // Patches: at most one random rectangle per 2.5 m cell.
    let (cx, cz) = ((x / 2.5).floor(), (z / 2.5).floor());
    let h = hash2(seed ^ 13, cx as i64, cz as i64);
    if unit(h) < 0.5 {
        let x0 = cx * 2.5 + 1.2 * unit(mix(h ^ 1));
        let z0 = cz * 2.5 + 1.2 * unit(mix(h ^ 2));
        let (w, d) = (0.4 + 0.9 * unit(mix(h ^ 3)), 0.4 + 0.9 * unit(mix(h ^ 4)));
        let f = fw.max(1e-6);
        let cover_x = ((x - x0 + 0.5 * f).min(w) - (x - x0 - 0.5 * f).max(0.0)).max(0.0) / f;
        let cover_z = ((z - z0 + 0.5 * f).min(d) - (z - z0 - 0.5 * f).max(0.0)).max(0.0) / f;
        let patch = if unit(mix(h ^ 5)) < 0.5 { 0.12 } else { 0.78 };
        g += (patch - g) * (cover_x * cover_z).min(1.0);
    }
    g.clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filtered_pulse_averages_to_the_duty_cycle() {
        // A filter many periods wide sees the mean coverage.
        let c = filtered_pulse(0.37, 0.2, 0.7, 40.0);
        assert!((c - 0.5).abs() < 0.02, "{c}");
        assert_eq!(filtered_pulse(0.5, 0.2, 0.7, 0.0), 1.0);
        assert_eq!(filtered_pulse(0.1, 0.2, 0.7, 0.0), 0.0);
    }

    #[test]
    fn same_place_same_shade_different_places_differ() {
        let f = Facade::new(42);
        assert_eq!(
            f.shade(3.3, 7.1, 0.01),
            Facade::new(42).shade(3.3, 7.1, 0.01)
        );
        let g = Facade::new(43);
        let differ = (0..100)
            .filter(|k| {
                (f.shade(*k as f64 * 0.37, 5.0, 0.01) - g.shade(*k as f64 * 0.37, 5.0, 0.01)).abs()
                    > 0.05
            })
            .count();
        assert!(differ > 50, "{differ}");
    }
}
