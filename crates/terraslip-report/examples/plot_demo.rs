//! Draws the kinds of plot terraslip reports use, into the directory given
//! as the first argument (default `.`).
use std::path::PathBuf;

use terraslip_report::{Heatmap, LinePlot, Series, SeriesStyle};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    let truth: Vec<(f64, f64)> = (0..300)
        .map(|i| (i as f64, if i < 120 { 0.60 } else { 0.72 }))
        .collect();
    let est: Vec<(f64, f64)> = (0..300)
        .map(|i| {
            let t = i as f64;
            let target = if i < 120 { 0.60 } else { 0.72 };
            (t, target - 0.1 * (-(t % 120.0) / 5.0).exp())
        })
        .collect();
    let band = est.iter().map(|&(t, v)| (t, v - 0.02, v + 0.02)).collect();
    LinePlot::new("ICR spread d = y_l - y_r", "time [s]", "d [m]")
        .band("estimate ±2σ", band, Some(5))
        .series(Series::line("truth", truth).style(SeriesStyle::Bold))
        .series(Series::line("estimate", est).color(5))
        .marker(120.0, "grass")
        .write_svg(&dir.join("line.svg"))?;
    let classes: Vec<String> = ["asphalt", "grass", "soil"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    Heatmap::confusion(
        "Confusion",
        &classes,
        &[vec![50, 2, 0], vec![3, 40, 5], vec![0, 1, 60]],
    )
    .write_svg(&dir.join("confusion.svg"))?;
    Ok(())
}
