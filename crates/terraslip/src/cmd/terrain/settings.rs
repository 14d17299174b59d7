//! The training flags `train` and `crossval` share, and the library's
//! [`TrainOptions`] they give.

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::ValueEnum;
use terraslip_terrain::{
    ChannelSet, ClassifierKind, RoiConfig, Source, TrainOptions, VibrationConfig,
    VibrationFeatureSet, VisionFeatureSet,
};

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum SourceArg {
    Imu,
    Camera,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ClassifierArg {
    /// wang2018: entropy decision tree with cost-complexity pruning.
    Tree,
    /// chen2023: k-nearest neighbours on standardised features.
    Knn,
    /// Gradient-boosted trees (default; softmax loss, depth-4 trees).
    Boost,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum FeaturesArg {
    /// imu: the paper's sign changes, mean, variance of accel_z (1 s windows unless --window).
    Paper,
    /// imu: moments, Welch band powers of every channel, tread speed and slip terms.
    Full,
    /// camera: lv2019's RGB histograms + uniform LBP.
    HistLbp,
    /// camera: chen2023's SFTA.
    Sfta,
    /// camera: both.
    Both,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ChannelsArg {
    /// All six IMU channels (accel x/y/z, gyro x/y/z).
    All,
    /// Vertical acceleration only.
    AccelZ,
}

/// Training settings shared by `train` and `crossval`.
#[derive(clap::Args, Clone)]
pub(super) struct TrainSettings {
    /// Sensor the model reads.
    #[arg(long, value_enum, default_value = "imu")]
    source: SourceArg,
    /// Classifier to train.
    #[arg(long, value_enum, default_value = "boost")]
    classifier: ClassifierArg,
    /// Feature set [default: full for imu, both for camera].
    #[arg(long, value_enum)]
    features: Option<FeaturesArg>,
    /// IMU window length, s [default: 6 (full), 1 (paper)]. Longer windows
    /// classify better (BorealTC leave-run-out: 1 s 75 %, 4 s 82 %, 6 s 86 %)
    /// but see a terrain change up to a window later.
    #[arg(long)]
    window: Option<f64>,
    /// Time between consecutive IMU windows, s.
    #[arg(long, default_value_t = 0.5)]
    hop: f64,
    /// IMU channels of the full feature set [default: all six when every
    /// training log has them, else accel-z].
    #[arg(long, value_enum)]
    channels: Option<ChannelsArg>,
    /// imu, full features: leave out the drive-motor current features
    /// (read by default when every training log has current_left,current_right).
    #[arg(long)]
    no_currents: bool,
    /// imu, full features: speed floor of the speed normalisation, m/s
    /// [default: chosen among 0.05, 0.1, 0.2 by cross-validation over the
    /// training runs].
    #[arg(long)]
    speed_floor: Option<f64>,
    /// imu, full features: speed factors of the training copies: every
    /// training log is also replayed as if driven r times as fast (IMU
    /// resampled in time, tread speeds times r, amplitude and currents by
    /// laws measured on the training runs), its windows kept where their
    /// terrain was not driven. Comma-separated, each > 0.
    #[arg(
        long,
        value_delimiter = ',',
        default_values_t = terraslip_terrain::augment::SpeedAugmentation::default().factors
    )]
    speed_copies: Vec<f64>,
    /// imu, full features: train on the recorded windows only (no speed copies).
    #[arg(long)]
    no_speed_copies: bool,
    /// Neighbours of the KNN classifier.
    #[arg(long, default_value_t = 5)]
    k: usize,
    /// Boosting rounds of the boosted trees (one tree per class each).
    #[arg(long, default_value_t = 150)]
    rounds: usize,
    /// Seed of the boosted trees (row samples and feature subsets).
    /// Leave-run-out figures on BorealTC move by about ±1 point with it.
    #[arg(long, default_value_t = 7)]
    seed: u64,
    /// imu, full features: leave out the slip terms (steering efficiency
    /// from gyro vs commanded yaw rate, spin share), as in model format 1.
    #[arg(long)]
    no_slip: bool,
    /// imu, full features: feed the classifier the raw log powers instead
    /// of mapping them to 0.5 m/s with speed slopes learnt from the training runs.
    #[arg(long)]
    no_speed_norm: bool,
    /// Pruning weight α of the decision tree (0 = no pruning).
    #[arg(long, default_value_t = 4.0)]
    prune_alpha: f64,
    /// camera: TOML file with chen2023's region of interest (a `[camera]`
    /// pinhole model plus horizon_s, length, width, margin); whole frames otherwise.
    #[arg(long)]
    pub(super) roi: Option<PathBuf>,
}

pub(super) fn options(s: &TrainSettings) -> anyhow::Result<TrainOptions> {
    let mut o = TrainOptions {
        source: match s.source {
            SourceArg::Imu => Source::Imu,
            SourceArg::Camera => Source::Camera,
        },
        ..TrainOptions::default()
    };
    o.classifier.kind = match s.classifier {
        ClassifierArg::Tree => ClassifierKind::Tree,
        ClassifierArg::Knn => ClassifierKind::Knn,
        ClassifierArg::Boost => ClassifierKind::Boost,
    };
    o.classifier.knn_k = s.k;
    o.classifier.boost.rounds = s.rounds;
    o.classifier.boost.seed = s.seed;
    o.classifier.tree.prune_alpha = s.prune_alpha;
    match (s.source, s.features) {
        (SourceArg::Imu, Some(FeaturesArg::Paper)) => o.vibration = VibrationConfig::paper(),
        (SourceArg::Imu, None | Some(FeaturesArg::Full)) => {}
        (SourceArg::Camera, None | Some(FeaturesArg::Both)) => {
            o.vision.features = VisionFeatureSet::Both
        }
        (SourceArg::Camera, Some(FeaturesArg::HistLbp)) => {
            o.vision.features = VisionFeatureSet::HistLbp
        }
        (SourceArg::Camera, Some(FeaturesArg::Sfta)) => o.vision.features = VisionFeatureSet::Sfta,
        (SourceArg::Imu, Some(_)) => bail!("--source imu takes --features paper or full"),
        (SourceArg::Camera, Some(_)) => {
            bail!("--source camera takes --features hist-lbp, sfta or both")
        }
    }
    if let Some(w) = s.window {
        if !(w.is_finite() && w > 0.0) {
            bail!("--window must be a positive number of seconds, got {w}");
        }
        o.vibration.window_s = w;
    }
    if !(s.hop.is_finite() && s.hop > 0.0) {
        bail!("--hop must be a positive number of seconds, got {}", s.hop);
    }
    o.vibration.hop_s = s.hop;
    if s.no_slip {
        o.vibration.slip = false;
    }
    if s.no_speed_norm {
        o.vibration.speed_norm = false;
    }
    if o.vibration.feature_set == VibrationFeatureSet::Full {
        o.imu_channels = s.channels.map(|c| match c {
            ChannelsArg::All => ChannelSet::All,
            ChannelsArg::AccelZ => ChannelSet::AccelZ,
        });
    }
    if s.no_currents {
        o.currents = Some(false);
    }
    if let Some(v) = s.speed_floor {
        if !(v.is_finite() && v > 0.0) {
            bail!("--speed-floor must be a positive speed in m/s, got {v}");
        }
        o.speed_floor = Some(v);
    }
    if s.no_speed_copies || o.vibration.feature_set != VibrationFeatureSet::Full {
        o.speed_augmentation = None;
    } else if let Some(aug) = &mut o.speed_augmentation {
        if let Some(r) = s
            .speed_copies
            .iter()
            .find(|r| !(r.is_finite() && **r > 0.0))
        {
            bail!("--speed-copies takes positive speed factors, got {r}");
        }
        aug.factors = s.speed_copies.clone();
    }
    if let Some(p) = &s.roi {
        let text =
            std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
        // toml's own message spans several lines (a source excerpt); the CLI
        // contract wants one.
        let roi: RoiConfig = toml::from_str(&text).map_err(|e| {
            let line = e
                .span()
                .map(|r| text[..r.start.min(text.len())].lines().count().max(1));
            anyhow::anyhow!(
                "{}:{}: bad region of interest: {}",
                p.display(),
                line.unwrap_or(0),
                e.message()
            )
        })?;
        o.vision.roi = Some(roi);
    }
    Ok(o)
}

/// The plain baseline beside every cross-validated figure: the same
/// source, window, channels and currents, boosted trees with their default
/// settings on the `full` features as measured (no speed normalisation,
/// slip terms or speed copies: nothing chosen on the runs).
pub(super) fn baseline_options(o: &TrainOptions) -> TrainOptions {
    let mut b = TrainOptions {
        source: o.source,
        vision: o.vision.clone(),
        imu_channels: o.imu_channels,
        currents: o.currents,
        speed_augmentation: None,
        ..TrainOptions::default()
    };
    b.vibration.window_s = o.vibration.window_s;
    b.vibration.hop_s = o.vibration.hop_s;
    b.vibration.speed_norm = false;
    b.vibration.slip = false;
    b
}
