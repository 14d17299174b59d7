use super::*;
use terraslip_io::{PoseObs, TerrainLabel};

fn straight_log(speed: f64, duration: f64) -> DriveLog {
    let mut log = DriveLog::default();
    for k in 0..=(duration * 20.0) as usize {
        let t = k as f64 * 0.05;
        log.wheels.push(WheelSample {
            t,
            v_left: speed,
            v_right: speed,
        });
        if k % 2 == 0 {
            log.pose.push(PoseObs {
                t,
                east: Some(0.0),
                north: Some(speed * t),
                yaw: Some(std::f64::consts::FRAC_PI_2),
                ..Default::default()
            });
        }
    }
    log
}

#[test]
fn increments_are_in_the_frame_of_the_segment_start() {
    // Heading north, moving north 1 m: 1 m forward, nothing sideways.
    let inc = relative((5.0, 5.0, std::f64::consts::FRAC_PI_2), (5.0, 6.0, 3.0));
    assert!((inc.dx - 1.0).abs() < 1e-12 && inc.dy.abs() < 1e-12);
    assert!((inc.dyaw - angle::wrap(3.0 - std::f64::consts::FRAC_PI_2)).abs() < 1e-12);
}

#[test]
fn segments_chain_at_least_min_duration_apart() {
    let log = straight_log(1.0, 20.0);
    let s = Segments::build(&[&log], &[0.0], &SegmentConfig::default());
    assert_eq!(s.len(), 20);
    for w in s.segments.windows(2) {
        assert_eq!(w[0].t1, w[1].t0);
    }
    for seg in &s.segments {
        assert!(seg.t1 - seg.t0 >= 1.0 - 1e-9);
        assert!((seg.reference.dx - (seg.t1 - seg.t0)).abs() < 1e-9);
        let steps = s.steps_of(seg);
        let dt: f64 = steps.iter().map(|x| x.dt).sum();
        assert!((dt - (seg.t1 - seg.t0)).abs() < 1e-9);
    }
}

#[test]
fn stationary_stale_and_implausible_segments_are_counted_not_used() {
    let mut log = straight_log(0.0, 10.0);
    // Standing still, with a millimetre of reference noise.
    for (k, p) in log.pose.iter_mut().enumerate() {
        p.east = Some(0.001 * (k % 2) as f64);
    }
    let s = Segments::build(&[&log], &[0.0], &SegmentConfig::default());
    assert_eq!(s.len(), 0);
    assert_eq!(s.stats.stationary, 10);
    assert_eq!(s.stats.stale_poses, 0);
    for p in log.pose.iter_mut() {
        p.east = Some(0.0);
    }
    // The treads drive 1 m/s but the pose never moves: a stalled localiser.
    for w in log.wheels.iter_mut() {
        w.v_left = 1.0;
        w.v_right = 1.0;
    }
    let s = Segments::build(&[&log], &[0.0], &SegmentConfig::default());
    assert_eq!(s.len(), 0);
    assert!(s.stats.stale_poses > 0);
    let mut log = straight_log(1.0, 10.0);
    // A 5 m jump cannot come from treads at 1 m/s.
    log.pose[50].north = log.pose[50].north.map(|n| n + 5.0);
    let s = Segments::build(&[&log], &[0.0], &SegmentConfig::default());
    assert!(s.stats.implausible >= 1);
}

#[test]
fn a_late_stamped_pose_is_dropped_and_a_clean_track_kept() {
    let log = straight_log(2.0, 10.0);
    let poses = clean_poses(&log.pose, &mut SegmentStats::default());
    assert_eq!(drop_mistimed(&poses, &log.wheels, 0.0).len(), poses.len());
    // Pose 20 (t = 2 s, poses 0.1 s apart) really shows where the
    // robot was at 1.92 s.
    let mut late = poses.clone();
    late[20].2 -= 2.0 * 0.08;
    let kept = drop_mistimed(&late, &log.wheels, 0.0);
    assert_eq!(kept.len(), poses.len() - 1);
    assert!(kept.iter().all(|p| p.0 != 2.0));
    // Whatever the slip: the same track at 60 % of the tread speed.
    let slow: Vec<_> = late.iter().map(|p| (p.0, p.1, 0.6 * p.2, p.3)).collect();
    assert_eq!(
        drop_mistimed(&slow, &log.wheels, 0.0).len(),
        poses.len() - 1
    );
}

#[test]
fn overlapping_segments_start_at_every_pose_and_report_their_coverage() {
    // Poses every 0.1 s, 1 m/s: chained segments are 1 s apart.
    let log = straight_log(1.0, 20.0);
    let chained = Segments::build(&[&log], &[0.0], &SegmentConfig::default());
    assert!((chained.coverage() - 1.0).abs() < 1e-9);
    assert!(chained.chained_mask().iter().all(|&k| k));
    let cfg = SegmentConfig {
        overlap: Some(0.0),
        ..Default::default()
    };
    let s = Segments::build(&[&log], &[0.0], &cfg);
    assert!(
        s.len() > 8 * chained.len(),
        "{} vs {}",
        s.len(),
        chained.len()
    );
    // Ten segments of 1 s start in every second.
    assert!((s.coverage() - 10.0).abs() < 0.6, "{}", s.coverage());
    assert!(s
        .segments
        .windows(2)
        .all(|w| w[1].t0 > w[0].t0 && w[1].t0 < w[0].t1));
    // Its chained subset is the chained segmentation.
    let mask = s.chained_mask();
    let sub: Vec<(f64, f64)> = s
        .segments
        .iter()
        .zip(&mask)
        .filter(|(_, &k)| k)
        .map(|(g, _)| (g.t0, g.t1))
        .collect();
    let want: Vec<(f64, f64)> = chained.segments.iter().map(|g| (g.t0, g.t1)).collect();
    assert_eq!(sub, want);
    // A 0.25 s stride, poses 0.1 s apart, segments of 10 poses: new
    // chains start at poses 0, 3, 6, 9, and then segments start where
    // one of them ended (10, 13, 16, 19, 20, ...): four chains, a few
    // more where a rounded pose time makes a segment 11 poses long.
    let cfg = SegmentConfig {
        overlap: Some(0.25),
        ..Default::default()
    };
    let s = Segments::build(&[&log], &[0.0], &cfg);
    assert!(s.coverage() > 3.9 && s.coverage() < 5.5, "{}", s.coverage());
    let starts: Vec<f64> = s.segments.iter().map(|g| g.t0).collect();
    for (a, b) in starts.iter().zip(&[0.0, 0.3, 0.6, 0.9, 1.0, 1.3]) {
        assert!((a - b).abs() < 1e-9, "{starts:?}");
    }
    // No start is more than the stride (rounded up to a pose) after the
    // previous one, and the starts after the first second also end a
    // segment (their noise enters the fit from both sides), but for the
    // few new chains (a start every third pose, the old rule, gives none).
    assert!(starts.windows(2).all(|w| w[1] - w[0] < 0.3 + 1e-9));
    let later: Vec<f64> = starts.iter().copied().filter(|&t| t >= 1.0).collect();
    let both = later
        .iter()
        .filter(|&&t| s.segments.iter().any(|h| h.t1 == t))
        .count();
    assert!(
        both as f64 > 0.9 * later.len() as f64,
        "{both} of {}",
        later.len()
    );
    assert_eq!(Segments::default().coverage(), 1.0);
}

#[test]
fn segments_across_a_terrain_change_are_skipped() {
    let mut log = straight_log(1.0, 10.0);
    log.terrain = vec![
        TerrainLabel {
            t: 0.0,
            terrain: "a".into(),
        },
        TerrainLabel {
            t: 4.5,
            terrain: "b".into(),
        },
    ];
    let s = Segments::build(&[&log], &[0.0], &SegmentConfig::default());
    assert_eq!(s.stats.terrain_change, 1);
    assert!(s.segments.iter().any(|x| x.terrain.as_deref() == Some("b")));
}

#[test]
fn a_long_drive_is_thinned_evenly_and_a_short_one_kept_whole() {
    // 1000 selected of 1500: every third left out.
    let mask: Vec<bool> = (0..1500).map(|i| i % 3 != 2).collect();
    assert_eq!(Segments::evenly_spread(&mask, 1000), mask);
    assert_eq!(Segments::evenly_spread(&mask, 5000), mask);
    let keep = Segments::evenly_spread(&mask, 100);
    assert_eq!(keep.iter().filter(|&&k| k).count(), 100);
    // Only selected ones, one in each tenth of the selection.
    assert!(keep.iter().zip(&mask).all(|(&k, &m)| !k || m));
    let at: Vec<usize> = (0..keep.len()).filter(|&i| keep[i]).collect();
    assert_eq!(at[0], 0);
    for (k, w) in at.windows(2).enumerate() {
        // 10 selected (15 in all) apart, give or take the left-out ones.
        assert!((14..=16).contains(&(w[1] - w[0])), "{k}: {w:?}");
    }
    for tenth in 0..10 {
        let n = at.iter().filter(|&&i| i / 150 == tenth).count();
        assert_eq!(n, 10, "tenth {tenth}");
    }
}

#[test]
fn a_subset_keeps_its_segments_increments_with_only_their_steps() {
    let log = straight_log(1.0, 40.0);
    let s = Segments::build(&[&log], &[0.0], &SegmentConfig::default());
    let keep: Vec<bool> = (0..s.len()).map(|i| i % 4 == 1).collect();
    let sub = s.subset(&keep);
    let kept: Vec<&Segment> = s
        .segments
        .iter()
        .zip(&keep)
        .filter(|(_, &k)| k)
        .map(|(g, _)| g)
        .collect();
    assert_eq!(sub.len(), kept.len());
    let total: usize = kept.iter().map(|g| g.steps.len()).sum();
    assert_eq!(sub.steps.len(), total);
    assert!(sub.steps.len() < s.steps.len() / 3);
    for (a, b) in sub.segments.iter().zip(kept) {
        assert_eq!((a.t0, a.t1, a.reference), (b.t0, b.t1, b.reference));
        assert_eq!(sub.steps_of(a), s.steps_of(b));
    }
}

#[test]
fn positions_and_headings_on_rows_of_their_own_make_the_same_segments() {
    let log = straight_log(1.0, 20.0);
    let joint = Segments::build(&[&log], &[0.0], &SegmentConfig::default());
    // As a GNSS import writes them: each position row, and 10 ms later a
    // heading row.
    let mut split = log.clone();
    split.pose = log
        .pose
        .iter()
        .flat_map(|p| {
            [
                PoseObs { yaw: None, ..*p },
                PoseObs {
                    t: p.t + 0.01,
                    east: None,
                    north: None,
                    ..*p
                },
            ]
        })
        .collect();
    let s = Segments::build(&[&split], &[0.0], &SegmentConfig::default());
    // The first position has no heading before it to interpolate from:
    // the chain starts at the next one (and ends a segment short).
    assert!(s.len() >= joint.len() - 2, "{} {}", s.len(), joint.len());
    assert_eq!(s.segments[0].t0, 0.1);
    for a in &s.segments {
        // 1 m/s straight ahead, whichever poses the segment joins.
        assert!((a.reference.dx - (a.t1 - a.t0)).abs() < 1e-9, "{a:?}");
        assert!(a.reference.dyaw.abs() < 1e-9);
    }
    // Positions alone: no segment, and the hint says why.
    let mut positions = log.clone();
    for p in &mut positions.pose {
        p.yaw = None;
    }
    let s = Segments::build(&[&positions], &[0.0], &SegmentConfig::default());
    assert_eq!(s.len(), 0);
    let hint = s.stats.hint(0);
    assert!(
        hint.contains("no position or no heading") && hint.contains("position-only"),
        "{hint}"
    );
    assert_eq!(
        joint.stats.hint(0),
        "is the robot moving while the pose reference is valid?"
    );
}
