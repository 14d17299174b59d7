//! A `diff_drive_controller` parameter file read back as a controller
//! takes it: the values its block sets, as written (comment lines are not
//! read, so a commented line leaves the controller's own value).

use yaml_rust2::{Yaml, YamlLoader};

/// The `diff_drive_controller` parameters one block of a parameter file
/// sets; `None` where the block does not set it (the controller keeps its
/// own).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WrittenParams {
    /// m.
    pub wheel_separation: Option<f64>,
    pub wheel_separation_multiplier: Option<f64>,
    /// m.
    pub wheel_radius: Option<f64>,
    pub left_wheel_radius_multiplier: Option<f64>,
    pub right_wheel_radius_multiplier: Option<f64>,
}

/// The block of node `controller` (`controller:` or `/controller:` at the
/// top level, its `ros__parameters`) in the parameter file `text`.
/// An empty or null `ros__parameters` sets nothing. Errors name the block
/// or the key and why.
pub fn read_block(text: &str, controller: &str) -> Result<WrittenParams, String> {
    let docs = YamlLoader::load_from_str(text).map_err(|e| format!("not YAML: {e}"))?;
    let root = docs.first().ok_or("an empty file: no controller block")?;
    let block = [controller.to_string(), format!("/{controller}")]
        .iter()
        .map(|k| &root[k.as_str()])
        .find(|b| !b.is_badvalue())
        .ok_or_else(|| format!("no block `{controller}`"))?;
    let params = &block["ros__parameters"];
    if params.is_badvalue() {
        return Err(format!("`{controller}` has no `ros__parameters`"));
    }
    let number = |key: &str| -> Result<Option<f64>, String> {
        match &params[key] {
            Yaml::BadValue | Yaml::Null => Ok(None),
            Yaml::Real(s) => s
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .map(Some)
                .ok_or_else(|| format!("`{controller}.{key}`: {s} is not a finite number")),
            Yaml::Integer(i) => Ok(Some(*i as f64)),
            other => Err(format!("`{controller}.{key}`: {other:?} is not a number")),
        }
    };
    Ok(WrittenParams {
        wheel_separation: number("wheel_separation")?,
        wheel_separation_multiplier: number("wheel_separation_multiplier")?,
        wheel_radius: number("wheel_radius")?,
        left_wheel_radius_multiplier: number("left_wheel_radius_multiplier")?,
        right_wheel_radius_multiplier: number("right_wheel_radius_multiplier")?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commented_lines_are_not_read() {
        let y = "# header\nc:\n  ros__parameters:\n    left_wheel_radius_multiplier: 0.96\n    \
                 # wheel_separation_multiplier: the controller's own x 0.95\n    \
                 right_wheel_radius_multiplier: 1\n";
        let p = read_block(y, "c").unwrap();
        assert_eq!(p.left_wheel_radius_multiplier, Some(0.96));
        assert_eq!(p.right_wheel_radius_multiplier, Some(1.0));
        assert_eq!(p.wheel_separation_multiplier, None);
        assert_eq!(p.wheel_separation, None);
    }

    #[test]
    fn an_empty_block_sets_nothing_and_bad_blocks_are_named() {
        let p = read_block("/c:\n  ros__parameters: {}\n", "c").unwrap();
        assert_eq!(p, WrittenParams::default());
        assert!(read_block("d:\n  ros__parameters: {}\n", "c")
            .unwrap_err()
            .contains("no block `c`"));
        let e = read_block("c:\n  ros__parameters:\n    wheel_radius: wide\n", "c").unwrap_err();
        assert!(e.contains("c.wheel_radius"), "{e}");
        assert!(read_block("c: [", "c").unwrap_err().starts_with("not YAML"));
    }
}
