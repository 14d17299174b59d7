use super::*;

#[test]
fn every_builtin_parses_and_validates() {
    for (name, _) in BUILTINS {
        let s = Scenario::builtin(name).unwrap();
        assert_eq!(&s.name, name);
        assert!(!s.description.is_empty(), "{name} has no description");
        assert!(s.duration() > 60.0);
    }
    let names = builtin_names();
    assert!(names.iter().any(|(n, _)| n == "papers-rtk"));
    assert!(!names.iter().any(|(n, _)| n == "p3at-calib-rtk"));
    let r = Scenario::builtin("papers-rtk").unwrap();
    assert!(r.gnss.total_std() < 0.05);
    assert_eq!(
        r.gnss.outages,
        Scenario::builtin("papers").unwrap().gnss.outages
    );
}

#[test]
fn papers_icr3_is_papers_with_unit_alpha() {
    let p = Scenario::builtin("papers").unwrap();
    let q = Scenario::builtin("papers-icr3").unwrap();
    for seg in &p.segments {
        let (a, b) = (
            p.terrain(&seg.terrain).unwrap(),
            q.terrain(&seg.terrain).unwrap(),
        );
        assert!(a.alpha_l < 1.0 && a.alpha_r < 1.0, "{}", seg.terrain);
        assert_eq!((b.alpha_l, b.alpha_r), (1.0, 1.0), "{}", seg.terrain);
        let robot = &p.robot;
        let (ia, ib) = (a.icr(robot), b.icr(robot));
        assert_eq!((ia.y_l, ia.y_r, ia.x_c), (ib.y_l, ib.y_r, ib.x_c));
    }
    // Everything but the name, description and terrain overrides is the same.
    let mut q2 = q.clone();
    q2.name = p.name.clone();
    q2.description = p.description.clone();
    q2.terrains = p.terrains.clone();
    assert_eq!(q2, p);
    assert!(builtin_names().iter().any(|(n, _)| n == "papers-icr3-rtk"));
}

#[test]
fn unknown_names_and_keys_are_errors() {
    let e = Scenario::builtin("nope").unwrap_err().to_string();
    assert!(e.contains("nope") && e.contains("papers"), "{e}");
    let text = "[[segment]]\nterrain = \"soil\"\nduration = 10\n[gnss]\nrat = 1\n";
    let e = Scenario::from_toml_str(text, Path::new("x.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("x.toml:5") && e.contains("rat"), "{e}");
}

#[test]
fn bad_values_are_named() {
    let base = "[[segment]]\nterrain = \"soil\"\nduration = 10\n";
    for (extra, key) in [
        ("[integration]\ndt = 0.01\n", "integration.dt"),
        ("[wheels]\nrate = -5\n", "wheels.rate"),
        ("[[segment]]\nterrain = \"lava\"\nduration = 5\n", "lava"),
        ("[gnss]\nwhite_std = nan\n", "gnss.white_std"),
        ("[imu]\nrate = 1e9\n", "imu.rate"),
        ("[imu]\ngyro_scale = 0.0\n", "imu.gyro_scale"),
        ("[imu]\ngyro_scale = nan\n", "imu.gyro_scale"),
        ("[integration]\ndt = 1e-9\n", "integration.dt"),
        ("[gnss]\nmultipath_rate = 50.0\n", "gnss.multipath_rate"),
        ("[drive]\nspeed = [1.0, 0.5]\n", "drive.speed"),
        ("[terrains.soil]\nchi = 3.0\n", "chi"),
    ] {
        let text = format!("{base}{extra}");
        let e = Scenario::from_toml_str(&text, Path::new("s.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains(key) && e.contains("s.toml"), "{extra:?}: {e}");
    }
    let e = Scenario::from_toml_str("name = \"x\"\n", Path::new("s.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("segment"), "{e}");
}
