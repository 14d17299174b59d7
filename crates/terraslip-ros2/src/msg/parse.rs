//! Parsing `ros2msg` definitions into a [`Registry`] and resolving field paths.

use super::{short_type, Arity, Field, MsgDef, Prim, Registry, Ty};

/// A raw field before its type is resolved.
struct RawField {
    ty: String,
    arity: Arity,
    name: String,
}

impl Registry {
    /// Parses a `ros2msg` definition of `root` (with its `MSG:` sections).
    /// Types it refers to but does not define are looked up in `fallback`
    /// (built-in definitions). Returns the index of the root message.
    pub fn parse(root: &str, text: &str, fallback: Option<&str>) -> Result<(Self, usize), String> {
        let mut sections: Vec<(String, Vec<RawField>)> = Vec::new();
        // An empty definition (older sqlite3 bags) leaves the root to `fallback`.
        if !text.trim().is_empty() {
            add_sections(&mut sections, &short_type(root), text)?;
        }
        if let Some(fb) = fallback {
            let mut extra = Vec::new();
            add_sections(&mut extra, "", fb)?;
            for s in extra {
                if !sections.iter().any(|(n, _)| *n == s.0) {
                    sections.push(s);
                }
            }
        }
        let mut reg = Registry::default();
        for (name, _) in &sections {
            if !reg.by_name.contains_key(name) {
                reg.by_name.insert(name.clone(), reg.msgs.len());
                reg.msgs.push(MsgDef {
                    name: name.clone(),
                    fields: Vec::new(),
                });
            }
        }
        for (name, raw) in &sections {
            let idx = reg.by_name[name];
            if !reg.msgs[idx].fields.is_empty() {
                continue;
            }
            let pkg = name.split('/').next().unwrap_or("");
            let mut fields = Vec::with_capacity(raw.len());
            for f in raw {
                let ty = match Prim::parse(&f.ty) {
                    Some(p) => Ty::Prim(p),
                    None => {
                        let full = resolve_name(&f.ty, pkg);
                        let i = reg.by_name.get(&full).copied().ok_or_else(|| {
                            format!(
                                "{name}: field `{}` has type `{full}` with no definition",
                                f.name
                            )
                        })?;
                        Ty::Msg(i)
                    }
                };
                fields.push(Field {
                    name: f.name.clone(),
                    ty,
                    arity: f.arity,
                });
            }
            reg.msgs[idx].fields = fields;
        }
        let root_idx = reg
            .by_name
            .get(&short_type(root))
            .copied()
            .ok_or_else(|| format!("definition has no type `{root}`"))?;
        reg.check_recursion(root_idx, 0)?;
        Ok((reg, root_idx))
    }

    fn check_recursion(&self, m: usize, depth: usize) -> Result<(), String> {
        if depth > 32 {
            return Err(format!(
                "{}: definition nests deeper than 32",
                self.msgs[m].name
            ));
        }
        for f in &self.msgs[m].fields {
            if let Ty::Msg(i) = f.ty {
                self.check_recursion(i, depth + 1)?;
            }
        }
        Ok(())
    }

    /// Resolves a dotted field path (`twist.twist.linear.x`) from message
    /// `root` into struct field indices.
    pub fn resolve(&self, root: usize, path: &str) -> Option<Vec<usize>> {
        let mut m = root;
        let mut out = Vec::new();
        let parts: Vec<&str> = path.split('.').collect();
        for (k, p) in parts.iter().enumerate() {
            let (i, f) = self.msgs[m]
                .fields
                .iter()
                .enumerate()
                .find(|(_, f)| f.name == *p)?;
            out.push(i);
            match (&f.ty, f.arity) {
                (Ty::Msg(j), Arity::One) => m = *j,
                _ if k + 1 == parts.len() => {}
                _ => return None,
            }
        }
        Some(out)
    }
}

fn resolve_name(ty: &str, pkg: &str) -> String {
    let t = short_type(ty);
    if t.contains('/') {
        t
    } else if t == "Header" {
        "std_msgs/Header".into()
    } else {
        format!("{pkg}/{t}")
    }
}

/// Splits a definition into `(type, fields)` sections.
fn add_sections(
    out: &mut Vec<(String, Vec<RawField>)>,
    root: &str,
    text: &str,
) -> Result<(), String> {
    let mut name = root.to_string();
    let mut fields = Vec::new();
    let mut started = !root.is_empty();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.starts_with("===") {
            if started {
                out.push((std::mem::take(&mut name), std::mem::take(&mut fields)));
            }
            started = false;
            continue;
        }
        if let Some(rest) = line.strip_prefix("MSG:") {
            name = short_type(rest.trim());
            started = true;
            continue;
        }
        let code = line.split('#').next().unwrap_or("").trim();
        if code.is_empty() {
            continue;
        }
        let mut it = code.split_whitespace();
        let (Some(ty), Some(fname)) = (it.next(), it.next()) else {
            return Err(format!("line {}: `{line}` is not `type name`", n + 1));
        };
        // Constants (`uint8 FOO=1`) are not serialised.
        if fname.contains('=') || it.clone().next().is_some_and(|s| s.starts_with('=')) {
            continue;
        }
        let (base, arity) = match ty.find('[') {
            Some(i) => {
                let inner = ty[i + 1..].trim_end_matches(']');
                let arity = if inner.is_empty() || inner.starts_with("<=") {
                    Arity::Seq
                } else {
                    Arity::Fixed(
                        inner
                            .parse()
                            .map_err(|_| format!("line {}: bad array size in `{ty}`", n + 1))?,
                    )
                };
                (&ty[..i], arity)
            }
            None => (ty, Arity::One),
        };
        if !started {
            return Err(format!("line {}: field before any `MSG:` line", n + 1));
        }
        fields.push(RawField {
            ty: base.to_string(),
            arity,
            name: fname.to_string(),
        });
    }
    if started {
        out.push((name, fields));
    }
    Ok(())
}
