use terraslip_terrain::*;
fn main() {
    let log = terraslip_io::DriveLog::read(std::env::args().nth(1).unwrap()).unwrap();
    let cfg = VisionConfig::default();
    let f = model::extract(
        &log,
        &Features::Vision {
            config: cfg,
            change_threshold: 1.0,
        },
    )
    .unwrap();
    let mut prev = None;
    for (t, _, phi) in f {
        let l = log.terrain_at(t).unwrap().to_string();
        let ch = prev.as_ref().map_or(false, |p: &String| *p != l);
        if ch || phi > 0.3 {
            println!("{t:7.1} {l:8} change={ch} phi={phi:.3}");
        }
        prev = Some(l);
    }
}
