//! The downward-looking ground camera: procedural textures anchored in the
//! world (so consecutive frames see the same stones moving under the robot),
//! with per-frame lighting and scale variation.
//!
//! The textures are hash noise, not photographs: what matters for the
//! classifiers is that each terrain has its own colour statistics and
//! structure at its own scale (aggregate speckle, clods, blades, joints,
//! pebbles, ripples) and that lighting and height change between frames.

use image::{Rgb, RgbImage};

use crate::scenario::Camera;
use crate::terrain::Texture;

/// Everything needed to render one frame later (frames are rendered lazily,
/// so simulating without writing images costs nothing).
#[derive(Debug, Clone, PartialEq)]
pub struct FrameSpec {
    /// s
    pub t: f64,
    /// Robot pose, ENU m and rad.
    pub east: f64,
    pub north: f64,
    pub yaw: f64,
    pub texture: Texture,
    /// Ground footprint width of this frame, m.
    pub footprint: f64,
    /// Brightness gain.
    pub gain: f64,
    /// Direction (rad, image frame) and strength of a brightness gradient
    /// (shadow of the robot, low sun).
    pub shade_dir: f64,
    pub shade: f64,
    /// Per-frame seed of the sensor noise.
    pub noise_seed: u32,
}

/// Distance ahead of the body origin of the image centre, m.
const LOOK_AHEAD: f64 = 0.35;

/// Renders `frame` at the camera's resolution.
pub fn render(frame: &FrameSpec, cam: &Camera) -> RgbImage {
    let (w, h) = (cam.width, cam.height);
    let mut img = RgbImage::new(w, h);
    let m_per_px = frame.footprint / w as f64;
    let (s, c) = frame.yaw.sin_cos();
    let (sd, cd) = frame.shade_dir.sin_cos();
    for py in 0..h {
        for px in 0..w {
            // Image up = robot forward, image right = robot right.
            let u = (px as f64 + 0.5 - 0.5 * w as f64) * m_per_px;
            let v = (0.5 * h as f64 - py as f64 - 0.5) * m_per_px;
            let xb = LOOK_AHEAD + v;
            let yb = -u;
            let e = frame.east + c * xb - s * yb;
            let n = frame.north + s * xb + c * yb;
            let rgb = texture(frame.texture, e, n);
            let nu = u / frame.footprint;
            let nv = v / frame.footprint;
            let light = frame.gain
                * (1.0 + frame.shade * (cd * nu + sd * nv))
                * (1.0 - 0.35 * (nu * nu + nv * nv));
            let grain = 0.025 * (hash(px as i64, py as i64, frame.noise_seed) - 0.5);
            let mut out = [0u8; 3];
            for k in 0..3 {
                out[k] = ((rgb[k] * light + grain).clamp(0.0, 1.0) * 255.0).round() as u8;
            }
            img.put_pixel(px, py, Rgb(out));
        }
    }
    img
}

/// Linear RGB in 0..1 of terrain `tex` at world point (`e`, `n`) m.
pub fn texture(tex: Texture, e: f64, n: f64) -> [f64; 3] {
    match tex {
        Texture::Asphalt => {
            let base = 0.24 + 0.07 * fbm(e * 30.0, n * 30.0, 3, 11);
            let (f1, _, id) = voronoi(e * 110.0, n * 110.0, 12);
            let stone = f1 < 0.32 && hash(id as i64, 0, 13) < 0.55;
            let g = if stone {
                0.38 + 0.25 * hash(id as i64, 1, 14)
            } else {
                base
            };
            [g, g * 1.01, g * 1.05]
        }
        Texture::Concrete => {
            let g = 0.62
                + 0.06 * fbm(e * 12.0, n * 12.0, 3, 21)
                + 0.05 * (value_noise(e * 220.0, n * 220.0, 22) - 0.5);
            let pore = hash((e * 400.0).floor() as i64, (n * 400.0).floor() as i64, 23) < 0.01;
            let crack = (fbm(e * 2.0, n * 2.0, 2, 24) - 0.5).abs() < 0.004;
            let g = if pore || crack { g * 0.55 } else { g };
            [g * 1.02, g, g * 0.96]
        }
        Texture::Soil => {
            let b = 0.6 + 0.6 * fbm(e * 18.0, n * 18.0, 5, 31);
            let (f1, _, id) = voronoi(e * 22.0, n * 22.0, 32);
            let clod = 1.0 - 0.35 * f1 + 0.12 * (hash(id as i64, 0, 33) - 0.5);
            let pebble = hash((e * 90.0).floor() as i64, (n * 90.0).floor() as i64, 34) < 0.015;
            let k = b * clod;
            if pebble {
                [0.55, 0.5, 0.45]
            } else {
                [0.42 * k, 0.30 * k, 0.20 * k]
            }
        }
        Texture::Grass => {
            // Blades: noise stretched along a direction that wanders slowly.
            let a = 1.5 * fbm(e * 1.5, n * 1.5, 2, 41);
            let (sa, ca) = a.sin_cos();
            let (x, y) = (ca * e + sa * n, -sa * e + ca * n);
            let blade = 0.6 * value_noise(x * 120.0, y * 10.0, 42)
                + 0.4 * value_noise(x * 260.0, y * 25.0, 45);
            let dry = fbm(e * 1.5, n * 1.5, 3, 43);
            let gap = fbm(e * 6.0, n * 6.0, 3, 44) < 0.25;
            if gap {
                let k = 0.7 + 0.3 * blade;
                return [0.35 * k, 0.27 * k, 0.18 * k];
            }
            let k = 0.45 + 0.75 * blade;
            [(0.12 + 0.25 * dry) * k, (0.32 + 0.15 * dry) * k, 0.08 * k]
        }
        Texture::Paving => {
            let (bw, bh, joint) = (0.20, 0.10, 0.008);
            let row = (n / bh).floor();
            let shift = if (row as i64).rem_euclid(2) == 1 {
                0.5 * bw
            } else {
                0.0
            };
            let col = ((e + shift) / bw).floor();
            let fx = (e + shift) - col * bw;
            let fy = n - row * bh;
            let in_joint = fx < joint || fy < joint;
            if in_joint {
                let g = 0.22 + 0.08 * value_noise(e * 300.0, n * 300.0, 51);
                return [g, g * 0.95, g * 0.85];
            }
            let id_h = hash(col as i64, row as i64, 52);
            let tone = 0.8 + 0.35 * id_h;
            let fine = 0.9 + 0.2 * value_noise(e * 150.0, n * 150.0, 53);
            let k = tone * fine;
            if hash(col as i64, row as i64, 54) < 0.3 {
                [0.45 * k, 0.44 * k, 0.42 * k]
            } else {
                [0.55 * k, 0.27 * k, 0.19 * k]
            }
        }
        Texture::Gravel => {
            let (f1, f2, id) = voronoi(e * 55.0, n * 55.0, 61);
            let h0 = hash(id as i64, 0, 62);
            let h1 = hash(id as i64, 1, 63);
            let dome = (1.0 - 1.4 * f1 * f1).max(0.2);
            let edge = if f2 - f1 < 0.06 { 0.35 } else { 1.0 };
            let k = (0.55 + 0.5 * h0) * dome * edge;
            [(0.50 + 0.12 * h1) * k, 0.47 * k, (0.42 - 0.08 * h1) * k]
        }
        Texture::Sand => {
            let warp = 0.02 * fbm(e * 8.0, n * 8.0, 3, 71);
            let ripple = ((e + 0.4 * n + warp) * std::f64::consts::TAU / 0.07).sin();
            let grain = value_noise(e * 400.0, n * 400.0, 72) - 0.5;
            let k = 1.0 + 0.06 * ripple + 0.08 * grain;
            [0.80 * k, 0.70 * k, 0.52 * k]
        }
    }
}

/// A uniform value in [0, 1) from a lattice point and a salt.
fn hash(x: i64, y: i64, salt: u32) -> f64 {
    let mut h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ (salt as u64).wrapping_mul(0x1656_67B1_9E37_79F9);
    h ^= h >> 33;
    h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    h ^= h >> 33;
    h = h.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
    h ^= h >> 33;
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Smooth value noise in [0, 1].
fn value_noise(x: f64, y: f64, salt: u32) -> f64 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (ix, iy) = (x0 as i64, y0 as i64);
    let sx = fx * fx * (3.0 - 2.0 * fx);
    let sy = fy * fy * (3.0 - 2.0 * fy);
    let a = hash(ix, iy, salt);
    let b = hash(ix + 1, iy, salt);
    let c = hash(ix, iy + 1, salt);
    let d = hash(ix + 1, iy + 1, salt);
    let top = a + (b - a) * sx;
    let bottom = c + (d - c) * sx;
    top + (bottom - top) * sy
}

/// Fractal sum of `octaves` value noises, normalised to [0, 1].
fn fbm(x: f64, y: f64, octaves: u32, salt: u32) -> f64 {
    let (mut sum, mut amp, mut norm, mut f) = (0.0, 1.0, 0.0, 1.0);
    for o in 0..octaves {
        sum += amp * value_noise(x * f, y * f, salt.wrapping_add(o * 101));
        norm += amp;
        amp *= 0.5;
        f *= 2.03;
    }
    sum / norm
}

/// Cellular noise: distances to the nearest and second-nearest feature point
/// (cell units) and the nearest cell's id.
fn voronoi(x: f64, y: f64, salt: u32) -> (f64, f64, u64) {
    let (cx, cy) = (x.floor() as i64, y.floor() as i64);
    let (mut f1, mut f2, mut id) = (f64::MAX, f64::MAX, 0u64);
    for dy in -1..=1 {
        for dx in -1..=1 {
            let (gx, gy) = (cx + dx, cy + dy);
            let px = gx as f64 + hash(gx, gy, salt);
            let py = gy as f64 + hash(gx, gy, salt ^ 0x5bd1);
            let d = (px - x).hypot(py - y);
            if d < f1 {
                f2 = f1;
                f1 = d;
                id = (gx as u64).wrapping_mul(73_856_093) ^ (gy as u64).wrapping_mul(19_349_663);
            } else if d < f2 {
                f2 = d;
            }
        }
    }
    (f1, f2, id)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(tex: Texture) -> FrameSpec {
        FrameSpec {
            t: 0.0,
            east: 3.0,
            north: -2.0,
            yaw: 0.7,
            texture: tex,
            footprint: 0.5,
            gain: 1.0,
            shade_dir: 0.0,
            shade: 0.1,
            noise_seed: 1,
        }
    }

    fn mean_rgb(img: &RgbImage) -> [f64; 3] {
        let mut m = [0.0; 3];
        for p in img.pixels() {
            for k in 0..3 {
                m[k] += p.0[k] as f64;
            }
        }
        m.map(|v| v / (img.width() * img.height()) as f64)
    }

    #[test]
    fn terrains_differ_in_colour() {
        let cam = Camera {
            width: 64,
            height: 48,
            ..Camera::default()
        };
        let grass = mean_rgb(&render(&frame(Texture::Grass), &cam));
        let soil = mean_rgb(&render(&frame(Texture::Soil), &cam));
        let asphalt = mean_rgb(&render(&frame(Texture::Asphalt), &cam));
        assert!(
            grass[1] > grass[0] && grass[1] > grass[2],
            "grass {grass:?}"
        );
        assert!(soil[0] > soil[2], "soil {soil:?}");
        assert!((asphalt[0] - asphalt[2]).abs() < 15.0 && asphalt[0] < 120.0);
    }

    #[test]
    fn lighting_scales_brightness_and_world_anchoring_holds() {
        let cam = Camera {
            width: 48,
            height: 48,
            ..Camera::default()
        };
        let mut f = frame(Texture::Gravel);
        let bright = mean_rgb(&render(&f, &cam));
        f.gain = 0.5;
        let dark = mean_rgb(&render(&f, &cam));
        assert!(dark[0] < 0.6 * bright[0]);
        // The same world point has the same texture whatever the pose.
        assert_eq!(
            texture(Texture::Paving, 1.234, 5.678),
            texture(Texture::Paving, 1.234, 5.678)
        );
        assert_ne!(
            texture(Texture::Gravel, 1.0, 1.0),
            texture(Texture::Gravel, 1.013, 1.0)
        );
    }
}
