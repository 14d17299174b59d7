//! Writes a long exact-model drive (50 Hz wheels, 1 Hz pose) for timing
//! `terraslip estimate` end to end:
//!     cargo run -p terraslip --release --example synth_log -- DIR [SECONDS]
fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    let dir = a
        .get(1)
        .ok_or_else(|| anyhow::anyhow!("usage: synth_log DIR [SECONDS]"))?;
    let duration = a.get(2).and_then(|s| s.parse().ok()).unwrap_or(3600.0);
    let spec = terraslip::testkit::SynthSpec {
        duration,
        ..Default::default()
    };
    terraslip::testkit::drive(&spec).write(dir)?;
    Ok(())
}
