//! Settings `train` chooses from its own training logs: the channels every
//! log has, and the speed floor of the speed normalisation (by inner
//! cross-validation over whole training runs).

use terraslip_io::DriveLog;

use crate::classify::{argmax, Classifier, ClassifierKind, ClassifierParams, Standardizer};
use crate::error::{Result, TerrainError};
use crate::speed_norm::SpeedNormalisation;
use crate::vibration::{ChannelSet, VibrationConfig, SPEED_FLOOR_CANDIDATES};

/// Whether every IMU row of the log has all six channels.
fn has_all_imu(log: &DriveLog) -> bool {
    !log.imu.is_empty()
        && log.imu.iter().all(|s| {
            s.accel_x.is_some()
                && s.accel_y.is_some()
                && s.gyro_x.is_some()
                && s.gyro_y.is_some()
                && s.gyro_z.is_some()
        })
}

/// Sets `cfg.channels` and `cfg.currents` from what the training logs have
/// where the caller left them open (`None`): all six IMU channels when every
/// log has them, else `accel_z`; currents when every log has them. Logs
/// that differ are an error naming one with and one without, since a model
/// reads the same channels from every log.
pub fn channels_from_logs(
    logs: &[DriveLog],
    cfg: &mut VibrationConfig,
    imu: Option<ChannelSet>,
    currents: Option<bool>,
) -> Result<()> {
    let mixed = |what: &str, with: &DriveLog, without: &DriveLog, flag: &str| {
        TerrainError::Training(format!(
            "{} has {what} but {} has not: a model reads the same channels from every log; \
             train on logs alike, or pass {flag}",
            with.name(),
            without.name()
        ))
    };
    cfg.channels = match imu {
        Some(c) => c,
        None => match (
            logs.iter().find(|l| has_all_imu(l)),
            logs.iter().find(|l| !has_all_imu(l)),
        ) {
            (Some(_), None) => ChannelSet::All,
            (None, _) => ChannelSet::AccelZ,
            (Some(a), Some(b)) => {
                return Err(mixed("all six IMU channels", a, b, "--channels accel-z"))
            }
        },
    };
    cfg.currents = match currents {
        Some(c) => c,
        None => match (
            logs.iter().find(|l| !l.currents.is_empty()),
            logs.iter().find(|l| l.currents.is_empty()),
        ) {
            (Some(_), None) => true,
            (None, _) => false,
            (Some(a), Some(b)) => {
                return Err(mixed(
                    "drive-motor currents (wheels.csv current_left,current_right)",
                    a,
                    b,
                    "--no-currents",
                ))
            }
        },
    };
    Ok(())
}

/// Inner folds of the speed-floor choice (over whole training runs).
pub const INNER_FOLDS: usize = 3;

/// The classifier of the inner cross-validation: the boosted trees with
/// fewer rounds (the choice needs the ranking of a few floors, not the
/// final accuracy), other kinds as given.
fn inner_params(p: &ClassifierParams) -> ClassifierParams {
    let mut q = p.clone();
    if q.kind == ClassifierKind::Boost {
        q.boost.rounds = q.boost.rounds.min(50);
    }
    q
}

/// The speed floor among [`SPEED_FLOOR_CANDIDATES`] whose speed
/// normalisation gives the best mean window accuracy when whole training
/// runs are left out: the runs (`run[i]` the run of window `i`, labels
/// `y`) are dealt round-robin by terrain to [`INNER_FOLDS`] folds. `None`
/// with fewer runs than folds or when no inner fold can be trained.
pub fn choose_speed_floor(
    x: &[Vec<f64>],
    y: &[usize],
    run: &[usize],
    run_class: &[usize],
    n_classes: usize,
    cfg: &VibrationConfig,
    params: &ClassifierParams,
) -> Option<f64> {
    let names = cfg.feature_names();
    let n_runs = run_class.len();
    if n_runs < INNER_FOLDS {
        return None;
    }
    // Round-robin by terrain, so every inner fold tests what it can.
    let mut fold_of = vec![0usize; n_runs];
    let mut next = 0;
    for c in 0..n_classes {
        for (r, _) in run_class.iter().enumerate().filter(|(_, &rc)| rc == c) {
            fold_of[r] = next % INNER_FOLDS;
            next += 1;
        }
    }
    let params = inner_params(params);
    let mut best: Option<(f64, f64)> = None;
    for &floor in &SPEED_FLOOR_CANDIDATES {
        let (mut hit, mut total) = (0usize, 0usize);
        for f in 0..INNER_FOLDS {
            let train: Vec<usize> = (0..x.len()).filter(|&i| fold_of[run[i]] != f).collect();
            let test: Vec<usize> = (0..x.len()).filter(|&i| fold_of[run[i]] == f).collect();
            if test.is_empty() {
                continue;
            }
            let xt: Vec<Vec<f64>> = train.iter().map(|&i| x[i].clone()).collect();
            let yt: Vec<usize> = train.iter().map(|&i| y[i]).collect();
            let Ok(sn) =
                SpeedNormalisation::fit(&xt, &yt, n_classes, &names, cfg.speed_norm_ref, floor)
            else {
                return None;
            };
            let mut xt = xt;
            xt.iter_mut().for_each(|r| sn.apply(r));
            let st = Standardizer::fit(&xt);
            let xs: Vec<Vec<f64>> = xt.iter().map(|r| st.apply(r)).collect();
            let Ok(model) = Classifier::fit(&xs, &yt, n_classes, &params) else {
                continue;
            };
            let mut p = vec![0.0; n_classes];
            for &i in &test {
                let mut r = x[i].clone();
                sn.apply(&mut r);
                model.predict_proba(&st.apply(&r), &mut p);
                hit += usize::from(argmax(&p) == y[i]);
                total += 1;
            }
        }
        if total == 0 {
            return None;
        }
        let acc = hit as f64 / total as f64;
        if best.is_none_or(|(_, a)| acc > a) {
            best = Some((floor, acc));
        }
    }
    best.map(|(f, _)| f)
}
