use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use crate::atomic::AtomicFile;
use crate::types::*;

fn opt(v: Option<f64>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}

/// Writes a CSV file atomically: `header`, then one line per item.
pub fn write_csv<T>(
    path: &Path,
    header: &str,
    items: &[T],
    mut row: impl FnMut(&T, &mut String),
) -> Result<(), LogError> {
    let mut f = AtomicFile::create(path)?;
    let mut buf = String::with_capacity(64 * 1024);
    buf.push_str(header);
    buf.push('\n');
    for it in items {
        row(it, &mut buf);
        buf.push('\n');
        if buf.len() > 60 * 1024 {
            f.write_all(buf.as_bytes())
                .map_err(|e| LogError::io(path, e))?;
            buf.clear();
        }
    }
    f.write_all(buf.as_bytes())
        .map_err(|e| LogError::io(path, e))?;
    f.commit()
}

impl DriveLog {
    /// Writes the log into `dir` (created if needed). Streams that are empty
    /// are not written; each file appears atomically.
    pub fn write(&self, dir: impl AsRef<Path>) -> Result<(), LogError> {
        let dir = dir.as_ref();
        std::fs::create_dir_all(dir).map_err(|e| LogError::io(dir, e))?;
        // Currents are written when every wheel row has its own.
        let currents = self.currents.len() == self.wheels.len()
            && self
                .currents
                .iter()
                .zip(&self.wheels)
                .all(|(c, w)| c.t == w.t);
        let header = if currents {
            "t,v_left,v_right,current_left,current_right"
        } else {
            "t,v_left,v_right"
        };
        write_csv(
            &dir.join("wheels.csv"),
            header,
            &self.wheels.iter().enumerate().collect::<Vec<_>>(),
            |(i, w), b| {
                let _ = write!(b, "{},{},{}", w.t, w.v_left, w.v_right);
                if currents {
                    let c = &self.currents[*i];
                    let _ = write!(b, ",{},{}", c.left, c.right);
                }
            },
        )?;
        if !self.pose.is_empty() {
            let with_std = self
                .pose
                .iter()
                .any(|p| p.std_xy.is_some() || p.std_yaw.is_some());
            let header = if with_std {
                "t,east,north,yaw,std_xy,std_yaw"
            } else {
                "t,east,north,yaw"
            };
            write_csv(&dir.join("pose.csv"), header, &self.pose, |p, b| {
                let _ = write!(b, "{},{},{},{}", p.t, opt(p.east), opt(p.north), opt(p.yaw));
                if with_std {
                    let _ = write!(b, ",{},{}", opt(p.std_xy), opt(p.std_yaw));
                }
            })?;
        }
        if !self.imu.is_empty() {
            write_csv(
                &dir.join("imu.csv"),
                "t,accel_x,accel_y,accel_z,gyro_x,gyro_y,gyro_z",
                &self.imu,
                |s, b| {
                    let _ = write!(
                        b,
                        "{},{},{},{},{},{},{}",
                        s.t,
                        opt(s.accel_x),
                        opt(s.accel_y),
                        s.accel_z,
                        opt(s.gyro_x),
                        opt(s.gyro_y),
                        opt(s.gyro_z)
                    );
                },
            )?;
        }
        if !self.images.is_empty() {
            write_csv(&dir.join("images.csv"), "t,path", &self.images, |i, b| {
                let _ = write!(b, "{},{}", i.t, i.path.display());
            })?;
        }
        if !self.terrain.is_empty() {
            write_csv(
                &dir.join("terrain.csv"),
                "t,terrain",
                &self.terrain,
                |l, b| {
                    let _ = write!(b, "{},{}", l.t, l.terrain);
                },
            )?;
        }
        if !self.truth.is_empty() {
            write_csv(
                &dir.join("truth.csv"),
                "t,east,north,yaw,y_l,y_r,x_c",
                &self.truth,
                |s, b| {
                    let _ = write!(
                        b,
                        "{},{},{},{},{},{},{}",
                        s.t, s.east, s.north, s.yaw, s.y_l, s.y_r, s.x_c
                    );
                },
            )?;
        }
        if self.meta != Meta::default() {
            let text = toml::to_string(&self.meta).map_err(|e| LogError::Invalid {
                path: dir.join("meta.toml"),
                reason: e.to_string(),
            })?;
            crate::write_atomic(dir.join("meta.toml"), text.as_bytes())?;
        }
        Ok(())
    }
}
