//! One simulated drive in memory, and writing it as a log directory.

use std::fmt::Write as _;
use std::path::Path;

use image::ImageEncoder as _;
use terraslip_io::{write_atomic, write_csv, AtomicFile, DriveLog};

use crate::camera;
use crate::{FrameSpec, Scenario, SimError, Terrain, TruthState};

/// One simulated drive, in memory.
#[derive(Debug, Clone)]
pub struct SimRun {
    /// The scenario that was run.
    pub scenario: Scenario,
    pub seed: u64,
    /// The sensor log (what the robot recorded) plus `truth` and `terrain`.
    /// `images` name files that exist only after [`SimRun::write`].
    pub log: DriveLog,
    /// Truth at `integration.truth_rate`, with alphas, twist and tread speeds.
    pub truth: Vec<TruthState>,
    /// The terrains of the drive, in order of first appearance.
    pub terrains: Vec<Terrain>,
    /// Camera frames to render (see [`SimRun::render_frame`]).
    pub frames: Vec<FrameSpec>,
    /// Start times of the terrain changes (the first segment excluded), s.
    pub terrain_changes: Vec<f64>,
}

impl SimRun {
    /// Renders camera frame `i` (see [`FrameSpec`]); `None` past the end.
    pub fn render_frame(&self, i: usize) -> Option<image::RgbImage> {
        self.frames
            .get(i)
            .map(|f| camera::render(f, &self.scenario.camera))
    }

    /// The truth state nearest before `t` (the first one before the start).
    pub fn truth_at(&self, t: f64) -> Option<&TruthState> {
        let i = self.truth.partition_point(|s| s.t <= t).saturating_sub(1);
        self.truth.get(i)
    }

    /// Writes the log directory (created if needed): the files of
    /// `log-format.md`, `truth.csv` with extra columns (alphas, body twist,
    /// terrain), `meta.toml` with the scenario and seed, the rendered
    /// `images/`, and the scenario itself as `scenario.toml`. Every file
    /// appears atomically.
    pub fn write(&self, dir: impl AsRef<Path>) -> Result<(), SimError> {
        self.write_with_progress(dir, |_, _| {})
    }

    /// As [`SimRun::write`], calling `progress(done, total)` after each frame.
    pub fn write_with_progress(
        &self,
        dir: impl AsRef<Path>,
        mut progress: impl FnMut(usize, usize),
    ) -> Result<(), SimError> {
        let dir = dir.as_ref();
        self.log.write(dir)?;
        // Richer truth than DriveLog knows about; readers ignore extra columns.
        write_csv(
            &dir.join("truth.csv"),
            "t,east,north,yaw,y_l,y_r,x_c,alpha_l,alpha_r,v_x,v_y,omega,terrain",
            &self.truth,
            |s, b| {
                let _ = write!(
                    b,
                    "{},{},{},{},{},{},{},{},{},{},{},{},{}",
                    s.t,
                    s.east,
                    s.north,
                    s.yaw,
                    s.icr.y_l,
                    s.icr.y_r,
                    s.icr.x_c,
                    s.icr.alpha_l,
                    s.icr.alpha_r,
                    s.twist.v_x,
                    s.twist.v_y,
                    s.twist.omega,
                    self.terrains[s.terrain].name
                );
            },
        )?;
        // The scenario and seed as top-level keys (written before any
        // table, such as `[pose]`, that would otherwise take them in).
        let mut table = toml::Table::try_from(&self.log.meta).unwrap_or_default();
        table.insert("scenario".into(), self.scenario.name.clone().into());
        // A seed over i64's range is written as the string of its digits.
        table.insert(
            "seed".into(),
            i64::try_from(self.seed).map_or_else(|_| self.seed.to_string().into(), Into::into),
        );
        let meta = format!(
            "# simulated by terraslip-sim {}\n{}",
            env!("CARGO_PKG_VERSION"),
            toml::to_string(&table).unwrap_or_default()
        );
        write_atomic(dir.join("meta.toml"), meta.as_bytes())?;
        let scen = toml::to_string(&self.scenario).map_err(|e| SimError::Scenario {
            path: dir.join("scenario.toml"),
            line: 0,
            reason: e.to_string(),
        })?;
        write_atomic(dir.join("scenario.toml"), scen.as_bytes())?;
        if !self.frames.is_empty() {
            let img_dir = dir.join("images");
            std::fs::create_dir_all(&img_dir).map_err(|e| SimError::Io {
                path: img_dir.clone(),
                source: e,
            })?;
            for (i, r) in self.log.images.iter().enumerate() {
                let img = camera::render(&self.frames[i], &self.scenario.camera);
                let path = dir.join(&r.path);
                let mut f = AtomicFile::create(&path)?;
                image::codecs::png::PngEncoder::new_with_quality(
                    &mut f,
                    image::codecs::png::CompressionType::Fast,
                    image::codecs::png::FilterType::Sub,
                )
                .write_image(
                    img.as_raw(),
                    img.width(),
                    img.height(),
                    image::ExtendedColorType::Rgb8,
                )
                .map_err(|e| SimError::Image {
                    path: path.clone(),
                    reason: e.to_string(),
                })?;
                f.commit()?;
                progress(i + 1, self.frames.len());
            }
        }
        Ok(())
    }
}
