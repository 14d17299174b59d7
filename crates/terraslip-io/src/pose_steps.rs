//! The steps between consecutive position fixes of `pose.csv`: a stream
//! whose fixes are stamped when they arrive rather than when they were
//! measured comes in bunches, many fixes a fraction of a millisecond apart
//! and then nothing for a while, so the step between two of them implies a
//! speed no ground robot reaches. The filter then compares each fix with
//! the wrong moment of the drive and gates many of them, silently; this
//! counts such steps for one warning.

use std::path::Path;

/// A step faster than this, m/s, is not a ground robot's motion.
const MAX_SPEED: f64 = 15.0;
/// Steps shorter than this, m, are left out (a fix's own noise).
const MIN_STEP: f64 = 1e-3;
/// The warning needs at least this many such steps...
const MIN_COUNT: usize = 10;
/// ...making at least this share of the steps between distinct positions.
const MIN_SHARE: f64 = 0.01;

/// Counts the steps between consecutive position fixes that imply more
/// than [`MAX_SPEED`].
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct PoseSteps {
    /// The previous fix: time, s; east, north, m.
    last: Option<(f64, f64, f64)>,
    /// Steps between distinct positions.
    steps: usize,
    /// Of which faster than [`MAX_SPEED`].
    fast: usize,
    /// Line of the first fast step.
    first_line: Option<u64>,
    /// The fastest step: speed, m/s; length, m; interval, s.
    fastest: (f64, f64, f64),
}

impl PoseSteps {
    /// Takes the fix at `line`, time `t` (s), position `east`, `north` (m).
    pub(crate) fn observe(&mut self, line: u64, t: f64, east: f64, north: f64) {
        if let Some((t0, e0, n0)) = self.last.replace((t, east, north)) {
            let d = (east - e0).hypot(north - n0);
            if d == 0.0 {
                return;
            }
            self.steps += 1;
            let dt = t - t0;
            if d >= MIN_STEP && d > MAX_SPEED * dt {
                self.fast += 1;
                self.first_line.get_or_insert(line);
                let v = if dt > 0.0 { d / dt } else { f64::INFINITY };
                if v > self.fastest.0 {
                    self.fastest = (v, d, dt);
                }
            }
        }
    }

    /// The warning when enough steps are too fast to be motion.
    pub(crate) fn warning(&self, path: &Path) -> Option<String> {
        let share = self.fast as f64 / self.steps.max(1) as f64;
        let line = self.first_line?;
        (self.fast >= MIN_COUNT && share >= MIN_SHARE).then(|| {
            let (_, d, dt) = self.fastest;
            format!(
                "{}:{line}: {} of {} steps between position fixes imply more than {MAX_SPEED:.0} m/s \
                 (the fastest {d:.3} m in {:.2} ms): the fixes look stamped when they arrived, in bunches, \
                 not when they were measured, so each is compared with the wrong moment of the drive; \
                 stamp them at measurement",
                path.display(),
                self.fast,
                self.steps,
                dt * 1e3,
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn warned(fixes: &[(f64, f64, f64)]) -> Option<String> {
        let mut s = PoseSteps::default();
        for (k, &(t, e, n)) in fixes.iter().enumerate() {
            s.observe(k as u64 + 2, t, e, n);
        }
        s.warning(Path::new("pose.csv"))
    }

    /// A robot at 1 m/s, a fix every `dt` s stamped at `stamp(k)`.
    fn drive(n: usize, dt: f64, stamp: impl Fn(usize) -> f64) -> Vec<(f64, f64, f64)> {
        (0..n).map(|k| (stamp(k), k as f64 * dt, 0.0)).collect()
    }

    #[test]
    fn fixes_stamped_on_arrival_in_bunches_are_named() {
        // 100 Hz motion capture delivered every 0.3 s, each bunch stamped
        // 0.1 ms apart from its arrival.
        let fixes = drive(3000, 0.01, |k| {
            (k / 30) as f64 * 0.3 + (k % 30) as f64 * 1e-4
        });
        let w = warned(&fixes).expect("a warning");
        assert!(w.starts_with("pose.csv:"), "{w}");
        assert!(w.contains("stamped when they arrived"), "{w}");
    }

    #[test]
    fn fixes_stamped_when_measured_are_not() {
        assert_eq!(warned(&drive(3000, 0.01, |k| k as f64 * 0.01)), None);
        // A fast robot (5 m/s) with a 10 Hz reference.
        assert_eq!(warned(&drive(300, 0.5, |k| k as f64 * 0.1)), None);
    }

    #[test]
    fn a_few_jumps_of_a_gnss_fix_are_not() {
        let mut fixes = drive(2000, 0.1, |k| k as f64 * 0.1);
        for k in [500, 1200, 1700] {
            fixes[k].2 = 30.0;
        }
        assert_eq!(warned(&fixes), None);
    }

    #[test]
    fn a_stationary_robot_is_not() {
        let fixes: Vec<_> = (0..1000).map(|k| (k as f64 * 1e-4, 1.0, 2.0)).collect();
        assert_eq!(warned(&fixes), None);
    }
}
