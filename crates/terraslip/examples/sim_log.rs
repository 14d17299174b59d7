//! Writes a simulated log (until `terraslip simulate` lands):
//!     cargo run -p terraslip --release --example sim_log -- SCENARIO DIR [SEED]
fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    let sc = terraslip_sim::Scenario::resolve(&a[1])?;
    let seed = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    let mut run = terraslip_sim::simulate(&sc, seed)?;
    run.log.images.clear();
    run.log.write(&a[2])?;
    Ok(())
}
