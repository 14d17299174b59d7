//! Collects the doc comments of the configuration structs (this crate's
//! `src/config/mod.rs` and the core's filter and belief settings), so that
//! `estimate --print-config` can print every key with its documentation
//! from one source: the doc comments themselves.

use std::fmt::Write as _;
use std::path::PathBuf;

fn main() {
    const SOURCES: [&str; 5] = [
        "src/config/mod.rs",
        "../terraslip-core/src/filter/config.rs",
        "../terraslip-core/src/filter/band.rs",
        "../terraslip-core/src/filter/measurement.rs",
        "../terraslip-core/src/terrain_belief.rs",
    ];
    let mut src = String::new();
    for path in SOURCES {
        println!("cargo:rerun-if-changed={path}");
        src.push_str(&std::fs::read_to_string(path).unwrap_or_default());
        src.push('\n');
    }
    let mut out = String::from("&[\n");
    let (mut owner, mut doc) = (None::<String>, Vec::<String>::new());
    for line in src.lines() {
        let t = line.trim();
        if let Some(d) = t.strip_prefix("///") {
            doc.push(d.trim().to_string());
            continue;
        }
        if t.starts_with("#[") {
            continue;
        }
        if let Some(rest) = t.strip_prefix("pub struct ") {
            owner = rest
                .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                .next()
                .map(str::to_string)
                .filter(|_| !t.ends_with(';'));
        } else if t == "}" {
            owner = None;
        } else if let (Some(o), Some(field)) = (owner.as_ref(), t.strip_prefix("pub ")) {
            if let Some((name, ty)) = field.split_once(':') {
                let ty = ty.trim().trim_end_matches(',');
                let text = doc.join(" ");
                let _ = writeln!(out, "    ({o:?}, {:?}, {ty:?}, {text:?}),", name.trim());
            }
        }
        doc.clear();
    }
    out.push(']');
    let dir = PathBuf::from(std::env::var_os("OUT_DIR").unwrap_or_default());
    if let Err(e) = std::fs::write(dir.join("config_docs.rs"), out) {
        println!("cargo:warning=config docs not generated: {e}");
    }
}
