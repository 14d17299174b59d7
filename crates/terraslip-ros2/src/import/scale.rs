//! The scale of the tread speeds: the separation S an odometry twist's
//! tread speeds are made with (v ∓ ω·S/2), or the wheel radius joint
//! velocities are multiplied by, when the topics file does not give it.
//!
//! Nothing learned needs the true value. Tread speeds made with S' = k·S
//! keep their mean and scale their difference by k; the ICR model's spread
//! y_l − y_r then comes out k times the true one and the speed factors are
//! unchanged (exactly when α_l = α_r, to first order in α_l − α_r
//! otherwise). So the learned spread divided by the S used is the factor by
//! which the controller's `wheel_separation_multiplier` is off, whatever S
//! was used. Likewise a nominal wheel radius scales every tread speed and
//! the speed factors absorb it. The nominal value comes from the bag's
//! `/robot_description` (URDF: the wheel joints' lateral offsets and the
//! wheel links' cylinder radius), else the track width of `[meta]`, else a
//! stated default.

use super::config::TopicsConfig;

/// The separation used when nothing tells one, m: a skid-steer
/// controller's effective separation is 1.5-2 track widths of 0.5-0.6 m.
pub const DEFAULT_SEPARATION: f64 = 1.0;
/// The wheel radius used when nothing tells one, m.
pub const DEFAULT_WHEEL_RADIUS: f64 = 0.1;

/// Wheel geometry read from a URDF.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct UrdfWheels {
    /// Lateral distance between the left and right wheel joints (mean of
    /// each side), m.
    pub separation: Option<f64>,
    /// The wheel links' cylinder radius (collision, else visual), m.
    pub radius: Option<f64>,
}

/// Reads the wheel joints of a URDF: continuous or revolute joints whose
/// name or child link contains `wheel`, left where their origin's y > 0.
pub fn urdf_wheels(xml: &str) -> Option<UrdfWheels> {
    let doc = roxmltree::Document::parse(xml).ok()?;
    let root = doc.root_element();
    let num = |s: &str| -> Vec<f64> {
        s.split_whitespace()
            .filter_map(|a| a.parse().ok())
            .collect()
    };
    let (mut left, mut right, mut links) = (Vec::new(), Vec::new(), Vec::new());
    for j in root.children().filter(|n| n.has_tag_name("joint")) {
        if !matches!(j.attribute("type"), Some("continuous" | "revolute")) {
            continue;
        }
        let child = j
            .children()
            .find(|n| n.has_tag_name("child"))
            .and_then(|c| c.attribute("link"))
            .unwrap_or("");
        let name = j.attribute("name").unwrap_or("");
        if !(name.to_lowercase().contains("wheel") || child.to_lowercase().contains("wheel")) {
            continue;
        }
        let y = j
            .children()
            .find(|n| n.has_tag_name("origin"))
            .and_then(|o| o.attribute("xyz"))
            .map(num)
            .and_then(|v| v.get(1).copied())
            .filter(|y| y.is_finite() && y.abs() > 1e-3);
        match y {
            Some(y) if y > 0.0 => left.push(y),
            Some(y) => right.push(y),
            None => continue,
        }
        links.push(child.to_string());
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let separation = (!left.is_empty() && !right.is_empty()).then(|| mean(&left) - mean(&right));
    let radius = root
        .children()
        .filter(|n| n.has_tag_name("link") && links.iter().any(|l| n.attribute("name") == Some(l)))
        .find_map(|link| {
            ["collision", "visual"].iter().find_map(|part| {
                link.descendants()
                    .filter(|n| n.has_tag_name(*part))
                    .flat_map(|n| n.descendants())
                    .find(|n| n.has_tag_name("cylinder"))
                    .and_then(|c| c.attribute("radius"))
                    .and_then(|r| r.parse::<f64>().ok())
                    .filter(|r| r.is_finite() && *r > 0.0)
            })
        });
    (separation.is_some() || radius.is_some()).then_some(UrdfWheels { separation, radius })
}

/// A value the tread speeds are made with, and where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Scale {
    pub value: f64,
    /// `given`, `urdf`, `track_width` or `default`.
    pub source: &'static str,
}

impl Scale {
    /// Whether it is the robot's own value (given), so that what is learned
    /// in it is absolute.
    pub fn is_given(&self) -> bool {
        self.source == "given"
    }
}

fn usable(v: Option<f64>) -> Option<f64> {
    v.filter(|v| v.is_finite() && *v > 0.0)
}

/// The first usable of `given` (the topics file), `urdf` and `meta`
/// (named `meta_name`), else `default`.
fn first(
    given: Option<f64>,
    urdf: Option<f64>,
    meta: Option<f64>,
    meta_name: &'static str,
    default: f64,
) -> Scale {
    [(given, "given"), (urdf, "urdf"), (meta, meta_name)]
        .into_iter()
        .find_map(|(v, source)| usable(v).map(|value| Scale { value, source }))
        .unwrap_or(Scale {
            value: default,
            source: "default",
        })
}

/// The separation for an odometry twist: the topics file's, else the URDF's
/// wheel joints', else the track width, else [`DEFAULT_SEPARATION`].
pub fn separation(cfg: &TopicsConfig, urdf: Option<&UrdfWheels>) -> Scale {
    first(
        cfg.wheels.separation,
        urdf.and_then(|u| u.separation),
        cfg.meta.track_width,
        "track_width",
        DEFAULT_SEPARATION,
    )
}

/// The wheel radius for joint velocities: the topics file's, else the
/// URDF's wheel cylinders, else `[meta] wheel_radius`, else
/// [`DEFAULT_WHEEL_RADIUS`].
pub fn wheel_radius(cfg: &TopicsConfig, urdf: Option<&UrdfWheels>) -> Scale {
    first(
        cfg.wheels.wheel_radius,
        urdf.and_then(|u| u.radius),
        cfg.meta.wheel_radius,
        "meta",
        DEFAULT_WHEEL_RADIUS,
    )
}

/// What a source means, for the import's decision lines.
pub fn describe(source: &str) -> &'static str {
    match source {
        "given" => "from the topics file: the robot's own, results are absolute",
        "urdf" => "from /robot_description (the wheel joints): a nominal scale, the controller's may differ",
        "track_width" | "meta" => "from [meta]: a nominal scale, the controller's may differ",
        _ => "a default, nothing in the bag tells it: a nominal scale",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const URDF: &str = r#"<?xml version="1.0"?>
<robot name="tb">
  <link name="base_link"/>
  <link name="left_wheel"><collision><geometry><cylinder radius="0.0352" length="0.02"/></geometry></collision></link>
  <link name="right_wheel"><visual><geometry><cylinder radius="0.0352" length="0.02"/></geometry></visual></link>
  <joint name="left_wheel_joint" type="continuous"><parent link="base_link"/><child link="left_wheel"/><origin xyz="0 0.1165 0.0402" rpy="-1.57 0 0"/></joint>
  <joint name="right_wheel_joint" type="continuous"><parent link="base_link"/><child link="right_wheel"/><origin xyz="0 -0.1165 0.0402" rpy="-1.57 0 0"/></joint>
  <joint name="caster" type="fixed"><parent link="base_link"/><child link="c"/><origin xyz="-0.1 0 0"/></joint>
</robot>"#;

    #[test]
    fn urdf_wheel_joints_give_separation_and_radius() {
        let u = urdf_wheels(URDF).unwrap();
        assert!((u.separation.unwrap() - 0.233).abs() < 1e-12);
        assert_eq!(u.radius, Some(0.0352));
        assert_eq!(urdf_wheels("<robot name='x'/>"), None);
        assert_eq!(urdf_wheels("not xml"), None);
    }

    #[test]
    fn the_separation_comes_from_the_first_source_that_tells() {
        let u = urdf_wheels(URDF).unwrap();
        let mut cfg = TopicsConfig::default();
        assert_eq!(separation(&cfg, None).source, "default");
        cfg.meta.track_width = Some(0.555);
        assert_eq!(separation(&cfg, None).value, 0.555);
        assert_eq!(separation(&cfg, Some(&u)).source, "urdf");
        cfg.wheels.separation = Some(1.04);
        let s = separation(&cfg, Some(&u));
        assert!(s.is_given() && s.value == 1.04);
        assert_eq!(
            wheel_radius(&TopicsConfig::default(), Some(&u)).value,
            0.0352
        );
    }
}
