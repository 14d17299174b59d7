//! A process killed (SIGKILL) at any moment while it writes a parameters
//! file leaves the file absent or whole, never half, and no temporary that
//! piles up or that a restart could take for the file.
//!
//! The writer is this test binary itself, re-run as a child that rewrites
//! the file in a loop (`writer_child`, ignored unless the parent starts it).
#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use terraslip_core::IcrParams;
use terraslip_io::{ParamEntry, ParamsFile};

const TARGET_ENV: &str = "TERRASLIP_KILLED_WRITER_TARGET";
const NAME: &str = "params.json";

/// A parameters file of realistic size (a few terrains), distinct per `k`.
fn params(k: u32) -> ParamsFile {
    let d = f64::from(k % 1000) * 1e-5;
    let mut pf = ParamsFile {
        params: Some(IcrParams::new(0.30 + d, -0.31 - d, 0.01)),
        ..Default::default()
    };
    for (i, t) in ["asphalt", "gravel", "grass", "sand", "snow"]
        .iter()
        .enumerate()
    {
        let p = IcrParams::new(0.3 + 0.05 * i as f64 + d, -0.3 - d, 0.02);
        pf.terrains.insert((*t).into(), ParamEntry::new(p));
    }
    pf
}

/// The child: rewrites the file until it is killed.
#[test]
#[ignore = "started by killed_at_random_moments_leaves_the_file_whole"]
fn writer_child() {
    let target = PathBuf::from(std::env::var(TARGET_ENV).expect("started by the parent"));
    for k in 0.. {
        params(k).write(&target).expect("writes");
    }
}

/// xorshift64*: the kill moments, seeded so a failure can be replayed.
struct Rng(u64);
impl Rng {
    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) % n
    }
}

fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != NAME)
        .collect()
}

#[test]
fn killed_at_random_moments_leaves_the_file_whole() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join(NAME);
    let exe = std::env::current_exe().unwrap();
    let mut rng = Rng(0x7e44_a51f_0024_b00b);
    let started = Instant::now();
    let mut whole = 0;
    for round in 0..20 {
        let mut child = Command::new(&exe)
            .args(["--ignored", "--exact", "writer_child", "--test-threads=1"])
            .env(TARGET_ENV, &target)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // From before its first write to deep in its loop.
        std::thread::sleep(Duration::from_micros(2_000 + rng.below(60_000)));
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        if target.exists() {
            let pf = ParamsFile::read(&target)
                .unwrap_or_else(|e| panic!("round {round}: the file is not whole: {e}"));
            let p = pf.params.expect("pooled set");
            assert!(p.y_l.is_finite() && p.y_r.is_finite() && p.x_c.is_finite());
            assert_eq!(pf.terrains.len(), 5, "round {round}");
            whole += 1;
        }
        // What the kill left beside the file: at most the temporary of the
        // process just killed (the next writer removes it), never under the
        // file's own name.
        let left = temporaries(dir.path());
        let own = format!(".{NAME}.{}.tmp", child.id());
        assert!(
            left.iter().all(|n| *n == own),
            "round {round}: temporaries of earlier writers are left: {left:?}"
        );
    }
    assert!(whole >= 5, "the writer wrote in only {whole} of 20 rounds");
    // A restart (here: one more write) recalls and then replaces the file,
    // and leaves nothing else.
    let before = ParamsFile::read(&target).unwrap();
    assert!(before.params.is_some());
    params(7).write(&target).unwrap();
    let after = ParamsFile::read(&target).unwrap();
    let want = params(7).params.unwrap();
    assert!((after.params.unwrap().y_l - want.y_l).abs() < 1e-12);
    assert_eq!(temporaries(dir.path()), Vec::<String>::new());
    assert!(started.elapsed() < Duration::from_secs(60));
}
