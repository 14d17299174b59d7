//! The terrain catalogue: how each ground makes a robot slip, shake and look.
//!
//! Slip is given robot-independently as steering efficiency `chi = W / (y_l -
//! y_r)` and eccentricity `e` (Mandow eqs. 9-10), so one catalogue serves
//! robots of any track width; a scenario may instead pin the ICRs in metres
//! (as the P3-AT scenarios do with Mandow's Tables I-II).
//!
//! The values are plausible, not measured: hard, high-friction ground resists
//! the lateral scrub of a turn most (low chi, Mandow: asphalt 0.69-0.76,
//! concrete 0.70-0.75), soft or slippery ground less or more depending on
//! sinkage; the rolling factors alpha drop below 1 where the tread sinks or
//! spins. The catalogue's alphas are the same on both sides: the terrain
//! acts on both treads alike, and a left/right difference (tyre pressure,
//! wear) belongs to the robot, so a scenario sets it per robot (the P3-AT
//! scenarios use Mandow's measured pairs).

use serde::{Deserialize, Serialize};
use terraslip_core::kinematics::IcrParams;

use crate::robot::Robot;

/// Names of the catalogue terrains.
pub const CATALOGUE: &[&str] = &[
    "asphalt", "concrete", "soil", "grass", "paving", "gravel", "sand",
];

/// What the ground camera sees.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Texture {
    Asphalt,
    Concrete,
    Soil,
    Grass,
    Paving,
    Gravel,
    Sand,
}

/// A terrain's parameters. In a scenario, `[terrains.NAME]` may give any
/// subset of these keys; the rest come from the catalogue entry `like`
/// (default: NAME itself).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TerrainSpec {
    /// Catalogue entry to take unspecified keys from (a new terrain needs one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub like: Option<String>,
    /// Steering efficiency W / (y_l - y_r), 0.2..1.05.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chi: Option<f64>,
    /// Eccentricity, Mandow's sign: -(y_l + y_r) / (y_l - y_r).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eccentricity: Option<f64>,
    /// Left / right tread ICR, m (REP-103). When both are given they replace
    /// `chi` and `eccentricity`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y_l: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y_r: Option<f64>,
    /// Longitudinal ICR coordinate, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x_c: Option<f64>,
    /// Effective / nominal rolling radius of each side.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha_l: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha_r: Option<f64>,
    /// RMS vertical vibration at 1 m/s, m/s^2 (grows as speed^0.8).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roughness: Option<f64>,
    /// Chassis resonance excited by this ground, Hz.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resonance_hz: Option<f64>,
    /// Damping ratio of that resonance, 0.05..1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping: Option<f64>,
    /// Spacing of regular joints (paving, concrete slabs), m; 0 = none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_spacing: Option<f64>,
    /// Peak of the knock a joint gives at 1 m/s, m/s^2.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_knock: Option<f64>,
    /// Random stone impacts per metre driven.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub impacts_per_m: Option<f64>,
    /// Camera texture.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<Texture>,
}

/// A fully resolved terrain.
#[derive(Debug, Clone, PartialEq)]
pub struct Terrain {
    pub name: String,
    pub chi: f64,
    pub eccentricity: f64,
    pub y_lr: Option<(f64, f64)>,
    pub x_c: f64,
    pub alpha_l: f64,
    pub alpha_r: f64,
    pub roughness: f64,
    pub resonance_hz: f64,
    pub damping: f64,
    pub joint_spacing: f64,
    pub joint_knock: f64,
    pub impacts_per_m: f64,
    pub texture: Texture,
}

impl Terrain {
    /// Nominal true ICRs of `robot` on this terrain.
    pub fn icr(&self, robot: &Robot) -> IcrParams {
        let (y_l, y_r) = self.y_lr.unwrap_or_else(|| {
            let d = robot.track_width / self.chi;
            (
                0.5 * d * (1.0 - self.eccentricity),
                -0.5 * d * (1.0 + self.eccentricity),
            )
        });
        IcrParams {
            y_l,
            y_r,
            x_c: self.x_c,
            alpha_l: self.alpha_l,
            alpha_r: self.alpha_r,
        }
    }

    pub(crate) fn validate(&self) -> Result<(), String> {
        let n = &self.name;
        let check = |key: &str, v: f64, lo: f64, hi: f64| {
            if v.is_finite() && v >= lo && v <= hi {
                Ok(())
            } else {
                Err(format!("terrain `{n}`: `{key}` = {v} outside {lo}..{hi}"))
            }
        };
        check("chi", self.chi, 0.2, 1.05)?;
        check("eccentricity", self.eccentricity, -0.5, 0.5)?;
        check("x_c", self.x_c, -2.0, 2.0)?;
        check("alpha_l", self.alpha_l, 0.5, 1.5)?;
        check("alpha_r", self.alpha_r, 0.5, 1.5)?;
        check("roughness", self.roughness, 0.0, 50.0)?;
        check("resonance_hz", self.resonance_hz, 0.5, 500.0)?;
        check("damping", self.damping, 0.02, 1.0)?;
        check("joint_spacing", self.joint_spacing, 0.0, 100.0)?;
        check("joint_knock", self.joint_knock, 0.0, 100.0)?;
        check("impacts_per_m", self.impacts_per_m, 0.0, 1000.0)?;
        if let Some((l, r)) = self.y_lr {
            check("y_l", l, -5.0, 5.0)?;
            check("y_r", r, -5.0, 5.0)?;
        }
        Ok(())
    }
}

/// A catalogue terrain by name.
pub fn catalogue(name: &str) -> Option<Terrain> {
    use Texture::*;
    // chi, eccentricity, x_c, alphas, roughness, resonance, damping, joints
    // (spacing, knock), stones per metre, texture.
    #[rustfmt::skip]
    let e = match name {
        //           chi   ecc    x_c     alpha          rough  f_res  zeta  joints        impacts
        "asphalt"  => (0.70,  0.02, -0.010, (0.994, 0.994), 0.25, 30.0, 0.30, (0.0, 0.0),  0.2, Asphalt),
        "concrete" => (0.73, -0.01, -0.012, (0.995, 0.995), 0.12, 36.0, 0.30, (3.0, 1.0),  0.0, Concrete),
        "soil"     => (0.62,  0.03,  0.015, (0.970, 0.970), 0.80, 14.0, 0.25, (0.0, 0.0),  0.6, Soil),
        "grass"    => (0.80, -0.02,  0.020, (0.980, 0.980), 0.45,  9.0, 0.45, (0.0, 0.0),  0.1, Grass),
        "paving"   => (0.75,  0.01, -0.005, (0.990, 0.990), 0.30, 24.0, 0.30, (0.20, 1.6), 0.0, Paving),
        "gravel"   => (0.66,  0.00,  0.010, (0.955, 0.955), 1.10, 21.0, 0.20, (0.0, 0.0),  6.0, Gravel),
        "sand"     => (0.55,  0.03,  0.030, (0.935, 0.935), 0.30,  6.0, 0.50, (0.0, 0.0),  0.0, Sand),
        _ => return None,
    };
    let (chi, ecc, x_c, (a_l, a_r), rough, f, z, (js, jk), imp, tex) = e;
    Some(Terrain {
        name: name.to_string(),
        chi,
        eccentricity: ecc,
        y_lr: None,
        x_c,
        alpha_l: a_l,
        alpha_r: a_r,
        roughness: rough,
        resonance_hz: f,
        damping: z,
        joint_spacing: js,
        joint_knock: jk,
        impacts_per_m: imp,
        texture: tex,
    })
}

impl TerrainSpec {
    /// Applies these overrides to the catalogue entry they are `like`.
    pub fn resolve(&self, name: &str) -> Result<Terrain, String> {
        let base_name = self.like.as_deref().unwrap_or(name);
        let mut t = catalogue(base_name).ok_or_else(|| {
            format!(
                "terrain `{name}`: `{base_name}` is not in the catalogue ({}); set `like`",
                CATALOGUE.join(", ")
            )
        })?;
        t.name = name.to_string();
        macro_rules! take {
            ($($f:ident),*) => { $( if let Some(v) = self.$f { t.$f = v; } )* };
        }
        take!(
            x_c,
            alpha_l,
            alpha_r,
            roughness,
            resonance_hz,
            damping,
            joint_spacing,
            joint_knock,
            impacts_per_m,
            texture
        );
        if let Some(v) = self.chi {
            t.chi = v;
        }
        if let Some(v) = self.eccentricity {
            t.eccentricity = v;
        }
        match (self.y_l, self.y_r) {
            (Some(l), Some(r)) => t.y_lr = Some((l, r)),
            (None, None) => {}
            _ => {
                return Err(format!(
                    "terrain `{name}`: give both `y_l` and `y_r` or neither"
                ))
            }
        }
        t.validate()?;
        Ok(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catalogue_icrs_are_plausible() {
        let robot = Robot::default();
        for name in CATALOGUE {
            let t = catalogue(name).unwrap();
            t.validate().unwrap();
            let p = t.icr(&robot);
            p.validate().unwrap();
            assert!(p.y_l > 0.5 * robot.track_width * 0.9, "{name}");
            assert!(p.y_r < -0.5 * robot.track_width * 0.9, "{name}");
            assert!((p.steering_efficiency(robot.track_width) - t.chi).abs() < 1e-12);
            assert!((p.eccentricity() - t.eccentricity).abs() < 1e-12);
        }
    }

    #[test]
    fn overrides_merge_with_catalogue() {
        let spec = TerrainSpec {
            like: Some("grass".into()),
            chi: Some(0.5),
            ..Default::default()
        };
        let t = spec.resolve("wet-grass").unwrap();
        assert_eq!(t.chi, 0.5);
        assert_eq!(t.texture, Texture::Grass);
        assert!(TerrainSpec::default().resolve("lava").is_err());
        let half = TerrainSpec {
            y_l: Some(0.3),
            ..Default::default()
        };
        assert!(half.resolve("soil").unwrap_err().contains("y_r"));
    }
}
