use std::path::Path;

use plotters::prelude::*;

use crate::plot::draw_err;
use crate::ReportError;

/// A labelled matrix drawn as coloured cells with the value printed in each
/// (confusion matrices: rows = true class, columns = predicted).
#[derive(Debug, Clone)]
pub struct Heatmap {
    pub title: String,
    pub row_title: String,
    pub col_title: String,
    pub row_labels: Vec<String>,
    pub col_labels: Vec<String>,
    /// Colour intensity of each cell, normalised to 0..1 by the caller (e.g.
    /// row fractions); values outside are clamped.
    pub intensity: Vec<Vec<f64>>,
    /// Text printed in each cell.
    pub text: Vec<Vec<String>>,
}

impl Heatmap {
    /// A confusion matrix from counts: cells coloured by row fraction and
    /// labelled "count\n(row %)".
    pub fn confusion(title: impl Into<String>, classes: &[String], counts: &[Vec<u64>]) -> Self {
        let mut intensity = Vec::new();
        let mut text = Vec::new();
        for row in counts {
            let total: u64 = row.iter().sum();
            let frac: Vec<f64> = row
                .iter()
                .map(|&c| {
                    if total > 0 {
                        c as f64 / total as f64
                    } else {
                        0.0
                    }
                })
                .collect();
            text.push(
                row.iter()
                    .zip(&frac)
                    .map(|(c, f)| format!("{c} ({:.0}%)", 100.0 * f))
                    .collect(),
            );
            intensity.push(frac);
        }
        Self {
            title: title.into(),
            row_title: "true terrain".into(),
            col_title: "predicted terrain".into(),
            row_labels: classes.to_vec(),
            col_labels: classes.to_vec(),
            intensity,
            text,
        }
    }

    pub fn to_svg(&self) -> Result<String, ReportError> {
        let (nr, nc) = (self.row_labels.len().max(1), self.col_labels.len().max(1));
        let cell = 110u32;
        let (left, top) = (140u32, 70u32);
        let size = (left + cell * nc as u32 + 20, top + cell * nr as u32 + 60);
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
            let e = |err| draw_err(&self.title, err);
            root.fill(&WHITE).map_err(e)?;
            let font = |s: u32| ("sans-serif", s).into_font();
            root.draw(&Text::new(self.title.clone(), (10, 10), font(20)))
                .map_err(e)?;
            root.draw(&Text::new(
                self.col_title.clone(),
                ((left + cell * nc as u32 / 2 - 60) as i32, 38),
                font(14),
            ))
            .map_err(e)?;
            root.draw(&Text::new(self.row_title.clone(), (10, 38), font(14)))
                .map_err(e)?;
            for (j, l) in self.col_labels.iter().enumerate() {
                let x = (left + cell * j as u32 + 8) as i32;
                root.draw(&Text::new(l.clone(), (x, (top - 16) as i32), font(13)))
                    .map_err(e)?;
            }
            for (i, l) in self.row_labels.iter().enumerate() {
                let y = (top + cell * i as u32 + cell / 2 - 6) as i32;
                root.draw(&Text::new(l.clone(), (10, y), font(13)))
                    .map_err(e)?;
                for j in 0..nc {
                    let v = self
                        .intensity
                        .get(i)
                        .and_then(|r| r.get(j))
                        .copied()
                        .unwrap_or(0.0);
                    let v = if v.is_finite() {
                        v.clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let shade = (255.0 * (1.0 - 0.85 * v)) as u8;
                    let (x0, y0) = (
                        (left + cell * j as u32) as i32,
                        (top + cell * i as u32) as i32,
                    );
                    let (x1, y1) = (x0 + cell as i32, y0 + cell as i32);
                    root.draw(&Rectangle::new(
                        [(x0, y0), (x1, y1)],
                        RGBColor(shade, shade, 255).filled(),
                    ))
                    .map_err(e)?;
                    root.draw(&Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1)))
                        .map_err(e)?;
                    let t = self
                        .text
                        .get(i)
                        .and_then(|r| r.get(j))
                        .cloned()
                        .unwrap_or_default();
                    let color = if v > 0.6 { WHITE } else { BLACK };
                    root.draw(&Text::new(
                        t,
                        (x0 + 8, y0 + cell as i32 / 2 - 6),
                        font(13).color(&color),
                    ))
                    .map_err(e)?;
                }
            }
            root.present().map_err(e)?;
        }
        Ok(out)
    }

    pub fn write_svg(&self, path: &Path) -> Result<(), ReportError> {
        let svg = self.to_svg()?;
        terraslip_io::write_atomic(path, svg.as_bytes())?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn confusion_prints_counts_and_row_percent() {
        let classes = vec!["ice".to_string(), "sand".to_string()];
        let h = Heatmap::confusion("c", &classes, &[vec![3, 1], vec![0, 4]]);
        assert_eq!(h.text[0][0], "3 (75%)");
        assert_eq!(h.text[1][1], "4 (100%)");
        let svg = h.to_svg().unwrap();
        assert!(svg.contains("ice") && svg.contains("3 (75%)"));
    }
}
