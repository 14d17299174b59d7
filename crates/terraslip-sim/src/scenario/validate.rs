//! [`Scenario::validate`]: every number checked, the error naming the key.

use super::{ManoeuvreKind, Scenario};

impl Scenario {
    /// Checks every number; the reason names the key.
    pub fn validate(&self) -> Result<(), String> {
        fn pos(name: &str, v: f64) -> Result<(), String> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("`{name}` = {v} must be a positive number"))
            }
        }
        fn nonneg(name: &str, v: f64) -> Result<(), String> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("`{name}` = {v} must be zero or positive"))
            }
        }
        fn range(name: &str, r: [f64; 2]) -> Result<(), String> {
            nonneg(name, r[0])?;
            nonneg(name, r[1])?;
            if r[0] <= r[1] {
                Ok(())
            } else {
                Err(format!("`{name}` = [{}, {}]: min above max", r[0], r[1]))
            }
        }
        let r = &self.robot;
        pos("robot.track_width", r.track_width)?;
        pos("robot.wheel_radius", r.wheel_radius)?;
        pos("robot.length", r.length)?;
        pos("robot.max_tread_speed", r.max_tread_speed)?;
        if self.segments.is_empty() {
            return Err("no `[[segment]]`: a scenario needs at least one terrain segment".into());
        }
        for (i, seg) in self.segments.iter().enumerate() {
            pos(&format!("segment[{i}].duration"), seg.duration)?;
            let spec = self
                .terrain(&seg.terrain)
                .map_err(|e| format!("segment[{i}]: {e}"))?;
            spec.icr(r)
                .validate()
                .map_err(|e| format!("terrain `{}`: {e}", seg.terrain))?;
        }
        for (name, spec) in &self.terrains {
            spec.resolve(name)?;
        }
        let s = &self.slip;
        if !(s.turn_sensitivity.abs() <= 0.5) {
            return Err("`slip.turn_sensitivity` beyond +-0.5 is not a plausible robot".into());
        }
        pos("slip.turn_rate_ref", s.turn_rate_ref)?;
        if !(s.speed_sensitivity.abs() <= 0.2) {
            return Err(
                "`slip.speed_sensitivity` beyond +-0.2 per m/s is not a plausible robot".into(),
            );
        }
        nonneg("slip.lag", s.lag)?;
        nonneg("slip.transition", s.transition)?;
        let d = &self.drive;
        range("drive.speed", d.speed)?;
        range("drive.spin_rate", d.spin_rate)?;
        range("drive.duration", d.duration)?;
        pos("drive.duration[1]", d.duration[1])?;
        if d.radii.is_empty() {
            return Err("`drive.radii` must not be empty".into());
        }
        for v in &d.radii {
            pos("drive.radii", *v)?;
        }
        let m = &d.mix;
        for (n, v) in [
            ("straight", m.straight),
            ("arc", m.arc),
            ("spin", m.spin),
            ("s_curve", m.s_curve),
            ("stop", m.stop),
        ] {
            nonneg(&format!("drive.mix.{n}"), v)?;
        }
        pos(
            "drive.mix (sum)",
            m.straight + m.arc + m.spin + m.s_curve + m.stop,
        )?;
        pos("drive.area_radius", d.area_radius)?;
        pos("drive.accel_limit", d.accel_limit)?;
        pos("drive.yaw_accel_limit", d.yaw_accel_limit)?;
        nonneg("drive.wheel_lag", d.wheel_lag)?;
        for (i, m) in d.manoeuvres.iter().enumerate() {
            pos(&format!("drive.manoeuvres[{i}].duration"), m.duration)?;
            for (n, v) in [
                ("speed", m.speed),
                ("radius", m.radius),
                ("rate", m.rate),
                ("period", m.period),
            ] {
                if !v.is_finite() {
                    return Err(format!("`drive.manoeuvres[{i}].{n}` is not a number"));
                }
            }
            if matches!(m.kind, ManoeuvreKind::Arc | ManoeuvreKind::SCurve) && m.radius == 0.0 {
                return Err(format!("`drive.manoeuvres[{i}].radius` must not be 0"));
            }
            if m.kind == ManoeuvreKind::SCurve && m.period <= 0.0 {
                return Err(format!("`drive.manoeuvres[{i}].period` must be positive"));
            }
        }
        let it = &self.integration;
        pos("integration.dt", it.dt)?;
        if it.dt > 0.001 + 1e-12 {
            return Err(format!(
                "`integration.dt` = {} s: at most 0.001 s, so the truth is not a filter's discretisation",
                it.dt
            ));
        }
        pos("integration.truth_rate", it.truth_rate)?;
        pos("wheels.rate", self.wheels.rate)?;
        pos("wheels.ticks_per_rev", self.wheels.ticks_per_rev)?;
        let g = &self.gnss;
        nonneg("gnss.rate", g.rate)?;
        nonneg("gnss.white_std", g.white_std)?;
        nonneg("gnss.markov_std", g.markov_std)?;
        pos("gnss.markov_tau", g.markov_tau)?;
        pos("gnss.reported_std", g.reported_std)?;
        nonneg("gnss.multipath_rate", g.multipath_rate)?;
        nonneg("gnss.multipath_jump", g.multipath_jump)?;
        range("gnss.multipath_duration", g.multipath_duration)?;
        for (i, v) in g.lever_arm.into_iter().enumerate() {
            if !(v.is_finite() && v.abs() <= 50.0) {
                return Err(format!(
                    "`gnss.lever_arm[{i}]` = {v} must be within +-50 m (where the antenna sits on the robot)"
                ));
            }
        }
        for (i, w) in g.outages.iter().enumerate() {
            nonneg(&format!("gnss.outages[{i}].start"), w.start)?;
            pos(&format!("gnss.outages[{i}].duration"), w.duration)?;
        }
        for (i, j) in g.jumps.iter().enumerate() {
            nonneg(&format!("gnss.jumps[{i}].start"), j.start)?;
            pos(&format!("gnss.jumps[{i}].duration"), j.duration)?;
            if !(j.east.is_finite() && j.north.is_finite()) {
                return Err(format!("`gnss.jumps[{i}]` offset is not a number"));
            }
        }
        let c = &self.compass;
        nonneg("compass.rate", c.rate)?;
        nonneg("compass.std_deg", c.std_deg)?;
        if !c.bias_deg.is_finite() {
            return Err("`compass.bias_deg` is not a number".into());
        }
        pos("compass.reported_std_deg", c.reported_std_deg)?;
        let m = &self.imu;
        nonneg("imu.rate", m.rate)?;
        nonneg("imu.accel_noise", m.accel_noise)?;
        nonneg("imu.gyro_noise", m.gyro_noise)?;
        if !m.gyro_bias.is_finite() {
            return Err("`imu.gyro_bias` is not a number".into());
        }
        if !(m.gyro_scale > 0.5 && m.gyro_scale < 2.0) {
            return Err(format!(
                "`imu.gyro_scale` = {}: expected within (0.5, 2)",
                m.gyro_scale
            ));
        }
        nonneg("imu.vibration_gain", m.vibration_gain)?;
        let c = &self.camera;
        nonneg("camera.rate", c.rate)?;
        if c.rate > 0.0 {
            if !(8..=4096).contains(&c.width) || !(8..=4096).contains(&c.height) {
                return Err(format!(
                    "camera {}x{} pixels: each side must be 8..4096",
                    c.width, c.height
                ));
            }
            pos("camera.footprint", c.footprint)?;
            nonneg("camera.scale_variation", c.scale_variation)?;
            if c.scale_variation >= 0.9 {
                return Err("`camera.scale_variation` must be below 0.9".into());
            }
            range("camera.lighting", c.lighting)?;
            pos("camera.lighting[0]", c.lighting[0])?;
        }
        // Rates and steps that would exhaust memory or never finish.
        if it.dt < 1e-5 {
            return Err(format!("`integration.dt` = {} s: at least 1e-5 s", it.dt));
        }
        for (name, rate) in [
            ("integration.truth_rate", it.truth_rate),
            ("wheels.rate", self.wheels.rate),
            ("gnss.rate", self.gnss.rate),
            ("compass.rate", self.compass.rate),
            ("imu.rate", self.imu.rate),
            ("camera.rate", self.camera.rate),
        ] {
            if rate > 10_000.0 {
                return Err(format!("`{name}` = {rate} Hz: at most 10000 Hz"));
            }
        }
        if self.gnss.multipath_rate > 1.0 {
            return Err(format!(
                "`gnss.multipath_rate` = {} per s: at most 1 (that is no longer the odd jump)",
                self.gnss.multipath_rate
            ));
        }
        if self.camera.rate * self.duration() > 100_000.0 {
            return Err(format!(
                "camera: {:.0} frames; at most 100000 per drive (lower `camera.rate`)",
                self.camera.rate * self.duration()
            ));
        }
        // A drive of days would exhaust memory long before it finished.
        if self.duration() > 36_000.0 {
            return Err(format!(
                "drive of {} s: at most 36000 s (10 h) per scenario",
                self.duration()
            ));
        }
        Ok(())
    }
}
