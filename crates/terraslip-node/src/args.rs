//! `--ros-args` as `rcl` takes them: `-r`/`--remap from:=to` (also
//! `__node:=`, `__ns:=`, and `node:from:=to` for this node only),
//! `-p`/`--param name:=value` (the value read as YAML), `--params-file
//! FILE.yaml` (the `ros__parameters` of `/**` and of this node), and
//! `--log-level` (accepted, ignored). Parameters are returned as a TOML
//! table: a parameter `filter.still_speed` is key `still_speed` of table
//! `filter`, so they map onto the keys of a TOML configuration.

use std::path::Path;

use yaml_rust2::{Yaml, YamlLoader};

use crate::NodeError;

/// What `--ros-args` said.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RosArgs {
    /// Topic remaps `from -> to`, in the order given.
    pub remaps: Vec<(String, String)>,
    /// `__node:=`: the node's name.
    pub node_name: Option<String>,
    /// `__ns:=`: the node's namespace.
    pub namespace: Option<String>,
    /// Parameters, files first then `-p`, in order (a later one wins).
    pub params: Vec<(String, toml::Value)>,
}

impl RosArgs {
    /// Parses the arguments of a `--ros-args` section for node `node`.
    pub fn parse(ros: &[String], node: &str) -> Result<Self, NodeError> {
        let mut out = RosArgs::default();
        let mut it = ros.iter();
        let bad = |arg: &str, reason: &str| NodeError::Args {
            arg: arg.into(),
            reason: reason.into(),
        };
        let mut cli_params = Vec::new();
        while let Some(flag) = it.next() {
            let mut value = |what: &str| {
                it.next()
                    .cloned()
                    .ok_or_else(|| bad(flag, &format!("needs {what} after it")))
            };
            match flag.as_str() {
                "-r" | "--remap" => {
                    let rule = value("a rule from:=to")?;
                    let Some((from, to)) = rule.split_once(":=") else {
                        return Err(bad(&rule, "a remap rule is from:=to"));
                    };
                    // `node:from:=to` applies to that node only.
                    let from = match from.split_once(':') {
                        Some((n, f)) if n == node || n == "/**" => f,
                        Some(_) => continue,
                        None => from,
                    };
                    match from {
                        "__node" | "__name" => out.node_name = Some(to.into()),
                        "__ns" => out.namespace = Some(to.into()),
                        _ => out.remaps.push((from.into(), to.into())),
                    }
                }
                "-p" | "--param" => {
                    let rule = value("a parameter name:=value")?;
                    let Some((name, v)) = rule.split_once(":=") else {
                        return Err(bad(&rule, "a parameter is name:=value"));
                    };
                    let y = YamlLoader::load_from_str(v)
                        .map_err(|e| bad(&rule, &format!("value is not YAML: {e}")))?;
                    let y = y.into_iter().next().unwrap_or(Yaml::Null);
                    cli_params.push((name.to_string(), to_toml(&y).map_err(|e| bad(&rule, &e))?));
                }
                "--params-file" => {
                    let file = value("a YAML file")?;
                    out.params.extend(params_file(Path::new(&file), node)?);
                }
                "--log-level" => {
                    value("a level")?;
                }
                "-e" | "--enclave" => {
                    value("an enclave")?;
                }
                other => {
                    return Err(bad(
                        other,
                        "unknown --ros-args flag; this node takes -r/--remap, -p/--param, --params-file and --log-level",
                    ))
                }
            }
        }
        out.params.extend(cli_params);
        Ok(out)
    }

    /// `topic` after the remaps (the first rule that matches it).
    pub fn remap(&self, topic: &str) -> String {
        let bare = topic.trim_start_matches('/');
        self.remaps
            .iter()
            .find(|(from, _)| from == topic || from.trim_start_matches('/') == bare)
            .map_or_else(|| topic.to_string(), |(_, to)| to.clone())
    }

    /// The parameters as a TOML table, dotted names as nested tables.
    pub fn params_table(&self) -> toml::Table {
        let mut root = toml::Table::new();
        for (name, v) in &self.params {
            let mut t = &mut root;
            let mut parts: Vec<&str> = name.split('.').collect();
            let last = parts.pop().unwrap_or_default();
            for p in parts {
                let e = t
                    .entry(p.to_string())
                    .or_insert_with(|| toml::Value::Table(toml::Table::new()));
                if !e.is_table() {
                    *e = toml::Value::Table(toml::Table::new());
                }
                t = e.as_table_mut().expect("made a table above");
            }
            t.insert(last.to_string(), v.clone());
        }
        root
    }
}

/// The parameters of `node` in a `--params-file`: those under `/**`, then
/// under the node's name (with or without namespace), each
/// `ros__parameters` mapping flattened to dotted names.
fn params_file(path: &Path, node: &str) -> Result<Vec<(String, toml::Value)>, NodeError> {
    let err = |reason: String| NodeError::ParamsFile {
        path: path.to_path_buf(),
        reason,
    };
    let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
    let docs = YamlLoader::load_from_str(&text).map_err(|e| err(e.to_string()))?;
    let mut out = Vec::new();
    let Some(Yaml::Hash(top)) = docs.into_iter().next() else {
        return Err(err(
            "expected a mapping of node names to `ros__parameters`".into()
        ));
    };
    for (k, v) in &top {
        let name = k.as_str().unwrap_or_default();
        let applies = name == "/**"
            || name.trim_start_matches('/') == node
            || name.rsplit('/').next() == Some(node);
        if !applies {
            continue;
        }
        match v {
            Yaml::Hash(h) => match h.get(&Yaml::String("ros__parameters".into())) {
                Some(p) => flatten("", p, &mut out).map_err(|e| err(format!("{name}: {e}")))?,
                None => return Err(err(format!("{name}: no `ros__parameters` mapping"))),
            },
            _ => return Err(err(format!("{name}: expected a mapping"))),
        }
    }
    Ok(out)
}

fn flatten(prefix: &str, y: &Yaml, out: &mut Vec<(String, toml::Value)>) -> Result<(), String> {
    match y {
        Yaml::Hash(h) => {
            for (k, v) in h {
                let k = match k {
                    Yaml::String(s) => s.clone(),
                    other => return Err(format!("key {other:?} is not a name")),
                };
                let name = if prefix.is_empty() {
                    k
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&name, v, out)?;
            }
            Ok(())
        }
        v => {
            out.push((
                prefix.to_string(),
                to_toml(v).map_err(|e| format!("{prefix}: {e}"))?,
            ));
            Ok(())
        }
    }
}

fn to_toml(y: &Yaml) -> Result<toml::Value, String> {
    Ok(match y {
        Yaml::Boolean(b) => toml::Value::Boolean(*b),
        Yaml::Integer(i) => toml::Value::Integer(*i),
        Yaml::Real(_) => toml::Value::Float(y.as_f64().ok_or("not a number")?),
        Yaml::String(s) => toml::Value::String(s.clone()),
        Yaml::Array(a) => toml::Value::Array(a.iter().map(to_toml).collect::<Result<_, _>>()?),
        Yaml::Null => return Err("empty value".into()),
        other => return Err(format!("{other:?} is not a parameter value")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(a: &[&str]) -> Vec<String> {
        a.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn remaps_params_and_files_map_onto_config_keys() {
        let dir = std::env::temp_dir().join(format!("terraslip-node-args-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("p.yaml");
        std::fs::write(
            &f,
            "/**:\n  ros__parameters:\n    lag: 0.5\n    filter:\n      still_speed: 0.02\nother_node:\n  ros__parameters:\n    lag: 9.0\nterraslip:\n  ros__parameters:\n    publish_tf: false\n",
        )
        .unwrap();
        let a = RosArgs::parse(
            &s(&[
                "-r",
                "/odom:=/wheel/odom",
                "-r",
                "other:/x:=/y",
                "-r",
                "__ns:=/robot",
                "--params-file",
                f.to_str().unwrap(),
                "-p",
                "lag:=0.25",
                "-p",
                "measurement.std_xy:=1",
            ]),
            "terraslip",
        )
        .unwrap();
        assert_eq!(a.remap("/odom"), "/wheel/odom");
        assert_eq!(a.remap("odom"), "/wheel/odom");
        assert_eq!(a.remap("/x"), "/x");
        assert_eq!(a.namespace.as_deref(), Some("/robot"));
        let t = a.params_table();
        // -p comes after the file: it wins.
        assert_eq!(t["lag"].as_float(), Some(0.25));
        assert_eq!(t["publish_tf"].as_bool(), Some(false));
        assert_eq!(t["filter"]["still_speed"].as_float(), Some(0.02));
        assert_eq!(t["measurement"]["std_xy"].as_integer(), Some(1));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_arguments_say_what_is_expected() {
        let e = RosArgs::parse(&s(&["-p", "lag"]), "n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("name:=value"), "{e}");
        let e = RosArgs::parse(&s(&["--wat"]), "n").unwrap_err().to_string();
        assert!(e.contains("--wat") && e.contains("--params-file"), "{e}");
        let e = RosArgs::parse(&s(&["--params-file", "/nonexistent.yaml"]), "n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent.yaml"), "{e}");
    }
}
