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

/// A URDF joint's place: its parent link and its origin (xyz, m; rpy, rad)
/// in the parent link's frame.
struct JointOrigin<'a> {
    parent: &'a str,
    xyz: [f64; 3],
    rpy: [f64; 3],
}

/// The link named in `j`'s `<parent>` or `<child>` (`tag`).
fn link_of<'a>(j: roxmltree::Node<'a, '_>, tag: &str) -> &'a str {
    j.children()
        .find(|n| n.has_tag_name(tag))
        .and_then(|c| c.attribute("link"))
        .unwrap_or("")
}

/// Reads the wheel joints of a URDF: continuous or revolute joints whose
/// name or child link contains `wheel`, placed in the base (the link named
/// `base_link` on the way up, else the tree's root) by composing the chain
/// of joints above them, whatever their type (fixed; prismatic and
/// revolute at zero, as a TurtleBot 4's wheel-drop joints); left where the
/// joint's y in the base > 0.
pub fn urdf_wheels(xml: &str) -> Option<UrdfWheels> {
    let doc = roxmltree::Document::parse(xml).ok()?;
    let root = doc.root_element();
    let num = |s: &str| -> [f64; 3] {
        let v: Vec<f64> = s
            .split_whitespace()
            .filter_map(|a| a.parse().ok())
            .collect();
        match v[..] {
            [a, b, c] if v.iter().all(|x| x.is_finite()) => [a, b, c],
            _ => [0.0; 3],
        }
    };
    let joints: Vec<_> = root
        .children()
        .filter(|n| n.has_tag_name("joint"))
        .collect();
    // Each link's joint from its parent.
    let mut above: std::collections::HashMap<&str, JointOrigin> = Default::default();
    for &j in &joints {
        let origin = j.children().find(|n| n.has_tag_name("origin"));
        let at = |a: &str| {
            origin
                .and_then(|o| o.attribute(a))
                .map(num)
                .unwrap_or([0.0; 3])
        };
        above.insert(
            link_of(j, "child"),
            JointOrigin {
                parent: link_of(j, "parent"),
                xyz: at("xyz"),
                rpy: at("rpy"),
            },
        );
    }
    let (mut left, mut right, mut links) = (Vec::new(), Vec::new(), Vec::new());
    for &j in &joints {
        if !matches!(j.attribute("type"), Some("continuous" | "revolute")) {
            continue;
        }
        let child = link_of(j, "child");
        let name = j.attribute("name").unwrap_or("");
        if !(name.to_lowercase().contains("wheel") || child.to_lowercase().contains("wheel")) {
            continue;
        }
        let y = in_base(&above, child).filter(|y| y.is_finite() && y.abs() > 1e-3);
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

/// The lateral offset (y, m) in the base of the joint above `link`: the
/// joints' origins composed up to `base_link` or the root; `None` on a
/// loop.
fn in_base(above: &std::collections::HashMap<&str, JointOrigin>, link: &str) -> Option<f64> {
    let mut p = [0.0; 3];
    let mut at = link;
    for _ in 0..=above.len() {
        let Some(j) = above.get(at).filter(|_| at != "base_link") else {
            return Some(p[1]);
        };
        let r = super::mount::from_rpy(j.rpy[0], j.rpy[1], j.rpy[2]);
        let q = super::mount::rotate(r, p);
        p = [q[0] + j.xyz[0], q[1] + j.xyz[1], q[2] + j.xyz[2]];
        at = j.parent;
    }
    None
}

/// A value the tread speeds are made with, and where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Scale {
    pub value: f64,
    /// `given`, `urdf`, `track_width`, `meta`, `odometry` (a base driver's
    /// odometry made from the same joints) or `default`.
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
        "odometry" => "the base driver's: its odometry is made from the same wheel joints with it",
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

    /// TurtleBot 4 (Create 3): each wheel's continuous joint sits at the
    /// origin of a prismatic wheel-drop joint, which holds the offset;
    /// base_footprint is the root, above base_link.
    const TB4: &str = r#"<robot name="tb4">
  <link name="base_footprint"/><link name="base_link"/>
  <link name="wheel_drop_left"/><link name="wheel_drop_right"/>
  <link name="left_wheel"><collision><geometry><cylinder radius="0.0360" length="0.02"/></geometry></collision></link>
  <link name="right_wheel"><collision><geometry><cylinder radius="0.0360" length="0.02"/></geometry></collision></link>
  <joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/><origin xyz="0 0 0.0061"/></joint>
  <joint name="wheel_drop_left_joint" type="prismatic"><parent link="base_link"/><child link="wheel_drop_left"/><origin xyz="0 0.1165 0.0402"/><axis xyz="0 0 1"/><limit lower="-0.0075" upper="0.0" effort="1" velocity="1"/></joint>
  <joint name="wheel_drop_right_joint" type="prismatic"><parent link="base_link"/><child link="wheel_drop_right"/><origin xyz="0 -0.1165 0.0402"/><axis xyz="0 0 1"/><limit lower="-0.0075" upper="0.0" effort="1" velocity="1"/></joint>
  <joint name="left_wheel_joint" type="continuous"><parent link="wheel_drop_left"/><child link="left_wheel"/><origin xyz="0 0 0" rpy="-1.5708 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="right_wheel_joint" type="continuous"><parent link="wheel_drop_right"/><child link="right_wheel"/><origin xyz="0 0 0" rpy="-1.5708 0 0"/><axis xyz="0 0 1"/></joint>
</robot>"#;

    #[test]
    fn wheel_joints_below_other_joints_are_placed_in_the_base() {
        let u = urdf_wheels(TB4).unwrap();
        assert!((u.separation.unwrap() - 0.233).abs() < 1e-9, "{u:?}");
        assert_eq!(u.radius, Some(0.036));
        // A yawed mount above the wheels turns their offsets.
        let turned = TB4.replace(
            r#"<origin xyz="0 0 0.0061"/>"#,
            r#"<origin xyz="0 0 0.0061" rpy="0 0 0"/>"#,
        );
        assert!((urdf_wheels(&turned).unwrap().separation.unwrap() - 0.233).abs() < 1e-9);
        let chassis = TB4
            .replace(r#"<parent link="base_link"/><child link="wheel_drop_left"/>"#, r#"<parent link="chassis"/><child link="wheel_drop_left"/>"#)
            .replace(r#"<parent link="base_link"/><child link="wheel_drop_right"/>"#, r#"<parent link="chassis"/><child link="wheel_drop_right"/>"#)
            .replace("</robot>", r#"<link name="chassis"/><joint name="c" type="fixed"><parent link="base_link"/><child link="chassis"/><origin xyz="0.1 0 0" rpy="0 0 3.14159265358979"/></joint></robot>"#);
        // The chassis turned half a turn: left and right swap, S stays.
        assert!((urdf_wheels(&chassis).unwrap().separation.unwrap() - 0.233).abs() < 1e-6);
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
