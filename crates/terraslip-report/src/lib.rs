//! Plots and report pages.
//!
//! Plots are SVG (no font files, no bitmap encoder to build; every browser and
//! `rsvg-convert` renders them). Every file is written atomically.
//!
//! ```no_run
//! use terraslip_report::{LinePlot, Series};
//! let plot = LinePlot::new("Spread d = y_l - y_r", "time [s]", "d [m]")
//!     .series(Series::line("truth", vec![(0.0, 0.6), (10.0, 0.62)]))
//!     .marker(5.0, "grass");
//! plot.write_svg(std::path::Path::new("d.svg")).unwrap();
//! ```

mod heatmap;
mod plot;
mod table;

pub use heatmap::Heatmap;
pub use plot::{Band, Figure, LinePlot, Series, SeriesStyle, PALETTE};
pub use table::{html_page, markdown_table, Section};

/// Error drawing or writing a report.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("drawing {what}: {reason}")]
    Draw { what: String, reason: String },
    #[error(transparent)]
    Io(#[from] terraslip_io::LogError),
}
