//! `terraslip-lab heldout`'s 2 s prediction table: per drive, each
//! model's mean error and clock offset.

/// A drive's row of the table: name, each model's (name, mean error m,
/// clock offset s), the number of segments.
pub type TableRow = (String, Vec<(String, f64, f64)>, usize);

/// Prints the table: one row per drive, one column per model, each cell
/// the mean error (m) and the clock offset (s).
pub fn print(rows: &[TableRow]) {
    let Some(first) = rows.first() else {
        return;
    };
    let heads: Vec<&str> = first.1.iter().map(|m| m.0.as_str()).collect();
    println!("| drive | segments | {} |", heads.join(" | "));
    println!("|---|---|{}", "---|".repeat(heads.len()));
    for (drive, cols, n) in rows {
        let cells: Vec<String> = cols
            .iter()
            .map(|(_, e, c)| format!("{e:.3} ({c:+.2} s)"))
            .collect();
        println!("| {drive} | {n} | {} |", cells.join(" | "));
    }
}

/// Each scored start's time (s) and each model's error there (m).
pub type Segments = Vec<(f64, Vec<f64>)>;

/// Writes a drive's per-segment errors to `dir/DRIVE.csv`: a column `t`
/// (s) and one per model (m).
pub fn write_segments(
    dir: &std::path::Path,
    drive: &str,
    models: &[&str],
    segs: &Segments,
) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)?;
    let mut text = String::from("t");
    for m in models {
        text += &format!(",{m}");
    }
    text.push('\n');
    for (t, e) in segs {
        text += &format!("{t:.3}");
        for e in e {
            text += &format!(",{e:.4}");
        }
        text.push('\n');
    }
    // Written beside, then moved: a reader never sees half a file.
    let (tmp, path) = (
        dir.join(format!(".{drive}.csv.tmp")),
        dir.join(format!("{drive}.csv")),
    );
    std::fs::write(&tmp, text)?;
    std::fs::rename(&tmp, &path)?;
    Ok(())
}
