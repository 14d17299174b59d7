//! Outputs never written over inputs: every path a command writes is
//! compared with every file and directory it reads, after resolving
//! symbolic links and `.`/`..` (an output that does not exist yet is
//! resolved through its deepest existing ancestor).

use std::path::{Component, Path, PathBuf};

/// An output path that is, or lies inside, one of the command's inputs.
#[derive(Debug, thiserror::Error)]
#[error("{flag} {output}: {relation} {input} ({what}), which the command reads; write the output somewhere else")]
pub struct OverInput {
    /// The option that named the output, e.g. `--out`.
    pub flag: String,
    /// The output path as given.
    pub output: PathBuf,
    /// How the output and the input meet, e.g. "this is inside".
    pub relation: &'static str,
    /// The input path as given.
    pub input: PathBuf,
    /// What the input is, e.g. "the log", "--init".
    pub what: String,
}

/// The paths a command reads, to check its outputs against.
#[derive(Debug, Default, Clone)]
pub struct Inputs {
    items: Vec<(PathBuf, PathBuf, String)>,
}

impl Inputs {
    /// No inputs.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `path` (a file, or a directory whose whole content is an input),
    /// named `what` in messages. A path that does not exist is left out:
    /// reading it fails on its own.
    pub fn add(&mut self, path: &Path, what: &str) -> &mut Self {
        if let Ok(real) = path.canonicalize() {
            self.items
                .push((path.to_path_buf(), real, what.to_string()));
        }
        self
    }

    /// Refuses `output` (named by option `flag`) when it is one of the
    /// inputs or lies inside an input directory.
    pub fn check(&self, flag: &str, output: &Path) -> Result<(), OverInput> {
        let out = resolve(output);
        for (given, real, what) in &self.items {
            let relation = if out == *real {
                "this is"
            } else if out.starts_with(real) {
                "this is inside"
            } else {
                continue;
            };
            return Err(OverInput {
                flag: flag.to_string(),
                output: output.to_path_buf(),
                relation,
                input: given.clone(),
                what: what.clone(),
            });
        }
        Ok(())
    }

    /// [`Inputs::check`] for a directory the command replaces as a whole:
    /// also refused when it holds an input.
    pub fn check_replaced(&self, flag: &str, dir: &Path) -> Result<(), OverInput> {
        self.check(flag, dir)?;
        let out = resolve(dir);
        match self
            .items
            .iter()
            .find(|(_, real, _)| real.starts_with(&out))
        {
            Some((given, _, what)) => Err(OverInput {
                flag: flag.to_string(),
                output: dir.to_path_buf(),
                relation: "this directory, replaced as a whole, holds",
                input: given.clone(),
                what: what.clone(),
            }),
            None => Ok(()),
        }
    }

    /// [`Inputs::check`] for an output directory and the files `names`
    /// written into it.
    pub fn check_dir(&self, flag: &str, dir: &Path, names: &[&str]) -> Result<(), OverInput> {
        self.check(flag, dir)?;
        names
            .iter()
            .try_for_each(|n| self.check(flag, &dir.join(n)))
    }
}

/// Two outputs of one run on the same path: the later would overwrite the
/// earlier.
#[derive(Debug, thiserror::Error)]
#[error("{flag} {output}: the same path as {other}, which {other_flag} writes; give each output its own path")]
pub struct SameOutput {
    /// The option that named the output, e.g. `--mcap`.
    pub flag: String,
    /// The output path as given.
    pub output: PathBuf,
    /// The option whose output it meets, e.g. `--out`.
    pub other_flag: String,
    /// That output's path (a file inside its directory, or the directory).
    pub other: PathBuf,
}

/// The paths one run writes, to refuse two of them on one path before
/// any work is done.
#[derive(Debug, Default, Clone)]
pub struct Outputs {
    /// Flag, path as given, path resolved.
    items: Vec<(String, PathBuf, PathBuf)>,
}

impl Outputs {
    /// No outputs.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the file `path` written for option `flag`; refused when an
    /// output added before is on the same path.
    pub fn file(&mut self, flag: &str, path: &Path) -> Result<&mut Self, SameOutput> {
        let real = resolve(path);
        if let Some((other_flag, other, _)) = self.items.iter().find(|(_, _, r)| *r == real) {
            return Err(SameOutput {
                flag: flag.to_string(),
                output: path.to_path_buf(),
                other_flag: other_flag.clone(),
                other: other.clone(),
            });
        }
        self.items
            .push((flag.to_string(), path.to_path_buf(), real));
        Ok(self)
    }

    /// Adds the directory `dir` of option `flag` and the files `names`
    /// written into it.
    pub fn dir(&mut self, flag: &str, dir: &Path, names: &[&str]) -> Result<&mut Self, SameOutput> {
        self.file(flag, dir)?;
        for n in names {
            self.file(flag, &dir.join(n))?;
        }
        Ok(self)
    }
}

/// `path` absolute, with symbolic links of its existing part resolved and
/// the rest appended with `.` and `..` applied.
pub fn resolve(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let parts: Vec<Component> = absolute.components().collect();
    for k in (1..parts.len()).rev() {
        let Ok(mut out) = parts[..k].iter().collect::<PathBuf>().canonicalize() else {
            continue;
        };
        for c in &parts[k..] {
            match c {
                Component::ParentDir => {
                    out.pop();
                }
                Component::CurDir => {}
                c => out.push(c),
            }
        }
        return out;
    }
    absolute
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_outputs_on_one_path_are_refused() {
        let d = tempfile::tempdir().unwrap();
        let est = d.path().join("est");
        let mut outputs = Outputs::new();
        outputs.dir("--out", &est, &["summary.json"]).unwrap();
        let e = outputs
            .clone()
            .file("--mcap", &d.path().join("x/../est/./summary.json"))
            .unwrap_err();
        assert_eq!(
            (e.other_flag.as_str(), e.other),
            ("--out", est.join("summary.json"))
        );
        assert!(outputs.clone().file("--mcap", &est).is_err());
        assert!(outputs.file("--mcap", &est.join("est.mcap")).is_ok());
    }

    #[test]
    fn outputs_on_or_inside_an_input_are_refused() {
        let d = tempfile::tempdir().unwrap();
        let log = d.path().join("log");
        std::fs::create_dir(&log).unwrap();
        let file = d.path().join("params.json");
        std::fs::write(&file, "{}").unwrap();
        let mut inputs = Inputs::new();
        inputs.add(&log, "the log").add(&file, "--init");
        inputs.add(&d.path().join("absent"), "never read");
        let refused = |p: &Path| inputs.check("--out", p).is_err();
        assert!(refused(&log));
        assert!(
            refused(&log.join("est/estimate.csv")),
            "not yet existing, inside"
        );
        assert!(refused(&d.path().join("x/../log/./y")), "another spelling");
        assert!(refused(&file));
        assert!(!refused(&d.path().join("est")));
        assert!(!refused(&d.path().join("absent")));
        assert!(
            !refused(&d.path().join("log2")),
            "a name starting like an input"
        );
        let e = inputs.check("--mcap", &log.join("x.mcap")).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "--mcap {}: this is inside {} (the log), which the command reads; write the output somewhere else",
                log.join("x.mcap").display(),
                log.display()
            )
        );
        let e = inputs
            .check_dir("--out", d.path(), &["params.json"])
            .unwrap_err();
        assert_eq!(e.relation, "this is");
        assert!(inputs
            .check_replaced("--out", &d.path().join("est"))
            .is_ok());
        let e = inputs.check_replaced("--out", d.path()).unwrap_err();
        assert!(e.to_string().contains("replaced as a whole, holds"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn symbolic_links_are_followed() {
        let d = tempfile::tempdir().unwrap();
        let log = d.path().join("log");
        std::fs::create_dir(&log).unwrap();
        std::os::unix::fs::symlink(&log, d.path().join("link")).unwrap();
        let mut inputs = Inputs::new();
        inputs.add(&log, "the log");
        assert!(inputs
            .check("--out", &d.path().join("link/new/estimate.csv"))
            .is_err());
    }
}
