//! The speed factors' turn law held at a calibration's: the filter's
//! model is the calibration's.

use super::*;
use crate::kinematics::TurnRateSlopes;

fn started_from(p: IcrParams) -> Filter {
    let prior = Prior {
        icr: p,
        ..prior(0.5)
    };
    Filter::new(
        &prior,
        FilterConfig::default(),
        MeasurementConfig::default(),
        band(0.5),
    )
    .unwrap()
}

#[test]
fn a_held_speed_law_gives_the_calibrations_twist() {
    let p = IcrParams {
        y_l: 0.45,
        y_r: -0.47,
        x_c: 0.02,
        alpha_l: 0.9,
        alpha_r: 0.93,
    };
    let law = TurnRateSlopes {
        k_spread: 0.0,
        k_alpha: -0.12,
    };
    let mut f = started_from(p);
    f.hold_speed_law(law.k_alpha).unwrap();
    assert_eq!(f.speed_law(), law.k_alpha);
    for (vl, vr) in [(0.4, 1.6), (1.0, 1.0), (1.2, -1.2), (-0.3, 0.9)] {
        f.predict(vl, vr, 0.05).unwrap();
        let want = law.twist(&p, vl, vr);
        let got = f.twist();
        for (a, b) in [
            (got.v_x, want.v_x),
            (got.v_y, want.v_y),
            (got.omega, want.omega),
        ] {
            assert!(
                (a - b).abs() < 1e-12,
                "({vl}, {vr}): {got:?} against {want:?}"
            );
        }
        // The ICRs in effect give the same twist from the measured speeds.
        let now = f.icr_now().twist(vl, vr);
        assert!((now.omega - want.omega).abs() < 1e-12, "{now:?}");
        assert!((now.v_x - want.v_x).abs() < 1e-12, "{now:?}");
    }
    // A turn at 1.2 m/s of difference: both factors 14.4 % lower.
    f.predict(0.4, 1.6, 0.05).unwrap();
    let straight = started_from(p);
    let mut free = straight.clone();
    free.predict(0.4, 1.6, 0.05).unwrap();
    assert!((f.twist().v_x / free.twist().v_x - (1.0 - 0.12 * 1.2)).abs() < 1e-12);
}

#[test]
fn a_speed_law_beyond_its_range_is_refused() {
    let mut f = started_from(IcrParams::no_slip(0.5));
    assert!(f.hold_speed_law(f64::NAN).is_err());
    assert!(f.hold_speed_law(2.5).is_err());
    assert_eq!(f.speed_law(), 0.0);
    f.predict(0.4, 1.6, 0.05).unwrap();
    let t = f.twist();
    let want = IcrParams::no_slip(0.5).twist(0.4, 1.6);
    assert!((t.omega - want.omega).abs() < 1e-12);
}
