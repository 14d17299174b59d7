use super::*;

/// Commands a fixed twist for `until` s and records what it was handed.
struct Fixed {
    twist: Twist,
    until: f64,
    wheels: Vec<WheelSample>,
    pose: Vec<PoseObs>,
    imu: Vec<ImuSample>,
    calls: Vec<f64>,
}

impl Fixed {
    fn new(v_x: f64, omega: f64, until: f64) -> Self {
        Self {
            twist: Twist {
                v_x,
                v_y: 0.0,
                omega,
            },
            until,
            wheels: Vec::new(),
            pose: Vec::new(),
            imu: Vec::new(),
            calls: Vec::new(),
        }
    }
}

impl Controller for Fixed {
    fn command(&mut self, s: &Sensed<'_>) -> Option<Twist> {
        self.calls.push(s.t);
        self.wheels.extend_from_slice(s.wheels);
        self.pose.extend_from_slice(s.pose);
        self.imu.extend_from_slice(s.imu);
        (s.t < self.until).then_some(self.twist)
    }
}

/// Sand east of x = 5 m, asphalt west of it.
fn two_grounds() -> Scenario {
    let mut sc = Scenario::builtin("papers").unwrap();
    sc.segments = vec![
        crate::scenario::Segment {
            terrain: "asphalt".into(),
            duration: 1.0,
        },
        crate::scenario::Segment {
            terrain: "sand".into(),
            duration: 1.0,
        },
    ];
    sc.camera.rate = 0.0;
    sc
}

fn east_of_5(east: f64, _: f64) -> usize {
    usize::from(east > 5.0)
}

#[test]
fn a_zero_command_leaves_the_robot_where_it_stands() {
    let sc = two_grounds();
    let mut c = Fixed::new(0.0, 0.0, 20.0);
    let run = simulate_closed_loop(&sc, &east_of_5, 0.3, 0.05, 30.0, &mut c, 4).unwrap();
    let last = run.truth.last().unwrap();
    assert_eq!((last.east, last.north, last.yaw), (0.0, 0.0, 0.3));
    assert!(run
        .log
        .wheels
        .iter()
        .all(|w| w.v_left == 0.0 && w.v_right == 0.0));
}

#[test]
fn the_controller_sees_every_sample_once_and_stops_the_run() {
    let sc = two_grounds();
    let mut c = Fixed::new(0.5, 0.2, 12.0);
    let run = simulate_closed_loop(&sc, &east_of_5, 0.0, 0.05, 60.0, &mut c, 4).unwrap();
    // Called every 50 ms up to the first call at or past 12 s, which ends it.
    assert_eq!(c.calls.len(), 241);
    assert!((c.calls[240] - 12.0).abs() < 1e-9);
    assert_eq!(c.wheels, run.log.wheels);
    assert_eq!(c.pose, run.log.pose);
    assert_eq!(c.imu, run.log.imu);
    assert!(run.truth.last().unwrap().t <= 12.0 + 1e-9);
    // Deterministic in the seed.
    let again = simulate_closed_loop(
        &sc,
        &east_of_5,
        0.0,
        0.05,
        60.0,
        &mut Fixed::new(0.5, 0.2, 12.0),
        4,
    )
    .unwrap();
    assert_eq!(again.truth, run.truth);
}

#[test]
fn the_ground_under_the_robot_sets_the_slip() {
    let sc = two_grounds();
    // East at 0.5 m/s with a slow turn: onto sand after about 10 s.
    let (v, w) = (0.5, 0.1);
    let mut c = Fixed::new(v, w, 30.0);
    let run = simulate_closed_loop(&sc, &east_of_5, 0.0, 0.05, 60.0, &mut c, 2).unwrap();
    assert_eq!(run.terrain_changes.len(), 1);
    let t_change = run.terrain_changes[0];
    let at = run.truth_at(t_change).unwrap();
    assert!(at.east > 4.9 && at.east < 5.1, "crossed at {} m", at.east);
    // Settled on each ground, the yaw rate is the terrain's ICR model of
    // the commanded tread speeds (nominal separation), the spread moved
    // by the slip model's few percent.
    let track = sc.robot.track_width;
    let (vl, vr) = (v - 0.5 * track * w, v + 0.5 * track * w);
    for (t, name) in [(t_change - 1.0, "asphalt"), (t_change + 5.0, "sand")] {
        let s = run.truth_at(t).unwrap();
        assert_eq!(run.terrains[s.terrain].name, name);
        let p = sc.terrain_icr(name).unwrap();
        let want = p.twist(vl, vr).omega;
        assert!(
            (s.twist.omega / want - 1.0).abs() < 0.03,
            "{name}: {} against {want}",
            s.twist.omega
        );
        assert!((s.v_left - vl).abs() < 1e-6 && (s.v_right - vr).abs() < 1e-6);
    }
    // Sand turns the robot at a little over half the commanded rate.
    let sand = run.truth_at(t_change + 5.0).unwrap().twist.omega;
    assert!(sand < 0.6 * w, "{sand}");
}

#[test]
fn bad_settings_are_errors() {
    let sc = two_grounds();
    for (period, len) in [(0.0, 10.0), (f64::NAN, 10.0), (0.05, f64::INFINITY)] {
        let e = simulate_closed_loop(
            &sc,
            &east_of_5,
            0.0,
            period,
            len,
            &mut Fixed::new(0.0, 0.0, 1.0),
            1,
        )
        .unwrap_err();
        assert!(e.to_string().contains("control period"), "{e}");
    }
}
