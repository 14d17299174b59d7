//! Noise processes of the simulated sensors.

use rand::rngs::StdRng;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::terrain::Terrain;

pub(crate) fn gauss(rng: &mut StdRng) -> f64 {
    StandardNormal.sample(rng)
}

/// First-order Gauss-Markov process with stationary std `sigma` and
/// correlation time `tau` s, exact discretisation for any step.
#[derive(Debug, Clone)]
pub(crate) struct GaussMarkov {
    sigma: f64,
    tau: f64,
    pub(crate) value: f64,
}

impl GaussMarkov {
    /// Starts in the stationary distribution.
    pub(crate) fn new(sigma: f64, tau: f64, rng: &mut StdRng) -> Self {
        Self {
            sigma,
            tau,
            value: sigma * gauss(rng),
        }
    }

    pub(crate) fn step(&mut self, dt: f64, rng: &mut StdRng) -> f64 {
        let phi = (-dt / self.tau).exp();
        self.value = phi * self.value + self.sigma * (1.0 - phi * phi).sqrt() * gauss(rng);
        self.value
    }
}

/// A knock: a decaying oscillation started by a joint or a stone.
#[derive(Debug, Clone, Copy)]
struct Knock {
    t0: f64,
    amp: f64,
}

const KNOCK_HZ: f64 = 45.0;
const KNOCK_TAU: f64 = 0.03;

/// Vertical chassis vibration: a resonance driven by the terrain's roughness
/// (AR(2), unit variance before scaling), plus knocks from regular joints and
/// random stones, all growing with speed.
#[derive(Debug, Clone)]
pub(crate) struct Vibration {
    y1: f64,
    y2: f64,
    knocks: Vec<Knock>,
    joints_passed: f64,
}

impl Vibration {
    pub(crate) fn new() -> Self {
        Self {
            y1: 0.0,
            y2: 0.0,
            knocks: Vec::new(),
            joints_passed: 0.0,
        }
    }

    /// Vertical acceleration (m/s^2, gravity excluded) at `t`, for a sample
    /// step `dt`, speed `speed` m/s and distance driven `odometer` m.
    pub(crate) fn sample(
        &mut self,
        t: f64,
        dt: f64,
        speed: f64,
        odometer: f64,
        terrain: &Terrain,
        gain: f64,
        rng: &mut StdRng,
    ) -> f64 {
        let speed = speed.abs();
        // AR(2) resonator; the Nyquist limit caps the usable resonance.
        let f = terrain.resonance_hz.min(0.45 / dt);
        let wn = std::f64::consts::TAU * f;
        let zeta = terrain.damping;
        let r = (-zeta * wn * dt).exp();
        let theta = wn * dt * (1.0 - zeta * zeta).max(0.01).sqrt();
        let a1 = 2.0 * r * theta.cos();
        let a2 = -r * r;
        let var = (1.0 - a2) / ((1.0 + a2) * ((1.0 - a2).powi(2) - a1 * a1));
        let w = gauss(rng) / var.max(1e-12).sqrt();
        let y = a1 * self.y1 + a2 * self.y2 + w;
        self.y2 = self.y1;
        self.y1 = y;
        // Rough ground shakes more the faster it is crossed; a motor hum
        // remains whenever the robot moves.
        let level = gain * (terrain.roughness * speed.powf(0.8) + 0.03 * speed.min(0.2) / 0.2);
        let mut a = level * y;

        if terrain.joint_spacing > 0.0 {
            let passed = (odometer / terrain.joint_spacing).floor();
            if passed > self.joints_passed {
                self.knocks.push(Knock {
                    t0: t,
                    amp: gain * terrain.joint_knock * speed * (0.8 + 0.4 * rng.gen::<f64>()),
                });
            }
            self.joints_passed = passed;
        }
        if terrain.impacts_per_m > 0.0 {
            let p = terrain.impacts_per_m * speed * dt;
            if rng.gen::<f64>() < p {
                self.knocks.push(Knock {
                    t0: t,
                    amp: gain * 2.0 * terrain.roughness * speed * rng.gen_range(0.5..2.0),
                });
            }
        }
        self.knocks.retain(|k| t - k.t0 < 6.0 * KNOCK_TAU);
        for k in &self.knocks {
            let s = t - k.t0;
            a += k.amp * (-s / KNOCK_TAU).exp() * (std::f64::consts::TAU * KNOCK_HZ * s).sin();
        }
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn gauss_markov_has_configured_std_and_correlation() {
        let mut rng = StdRng::seed_from_u64(3);
        let mut gm = GaussMarkov::new(2.0, 10.0, &mut rng);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| gm.step(1.0, &mut rng)).collect();
        let var = xs.iter().map(|x| x * x).sum::<f64>() / n as f64;
        assert!((var.sqrt() - 2.0).abs() < 0.1, "std {}", var.sqrt());
        let lag = 10;
        let cov = xs.windows(lag + 1).map(|w| w[0] * w[lag]).sum::<f64>() / (n - lag) as f64;
        let rho = cov / var;
        assert!((rho - (-1.0f64).exp()).abs() < 0.05, "rho {rho}");
    }

    #[test]
    fn vibration_grows_with_roughness_and_speed() {
        let soil = crate::terrain::catalogue("soil").unwrap();
        let asphalt = crate::terrain::catalogue("asphalt").unwrap();
        let rms = |t: &Terrain, v: f64| {
            let mut rng = StdRng::seed_from_u64(5);
            let mut vib = Vibration::new();
            let n = 20_000;
            let s: f64 = (0..n)
                .map(|i| {
                    let tt = i as f64 * 0.005;
                    vib.sample(tt, 0.005, v, v * tt, t, 1.0, &mut rng).powi(2)
                })
                .sum();
            (s / n as f64).sqrt()
        };
        assert!(rms(&soil, 0.8) > 2.0 * rms(&asphalt, 0.8));
        assert!(rms(&soil, 1.0) > 1.5 * rms(&soil, 0.4));
        assert!(rms(&soil, 0.0) < 1e-9);
    }
}
