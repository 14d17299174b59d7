//! The ROS 2 environment variables a node honours, read as `rcl` reads
//! them: `ROS_DOMAIN_ID`, and how far discovery reaches
//! (`ROS_AUTOMATIC_DISCOVERY_RANGE`, Iron and later; `ROS_LOCALHOST_ONLY`,
//! Humble).

use crate::NodeError;

/// How far the node looks for peers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DiscoveryRange {
    /// The host only: loopback (127.0.0.1).
    Localhost,
    /// The host's networks (the DDS default).
    Subnet,
}

/// The environment as it concerns joining the graph.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RosEnv {
    /// DDS domain, 0..=232 (`ROS_DOMAIN_ID`, default 0).
    pub domain_id: u16,
    pub range: DiscoveryRange,
}

impl RosEnv {
    /// Reads the process environment.
    pub fn from_env() -> Result<Self, NodeError> {
        Self::from_vars(|k| std::env::var(k).ok())
    }

    /// Reads variables through `var` (for tests). `ROS_AUTOMATIC_DISCOVERY_RANGE`
    /// wins over `ROS_LOCALHOST_ONLY` when both are set, as in Jazzy.
    pub fn from_vars(var: impl Fn(&str) -> Option<String>) -> Result<Self, NodeError> {
        let bad = |name: &str, value: &str, want: &str| NodeError::Env {
            name: name.into(),
            value: value.into(),
            reason: want.into(),
        };
        let domain_id = match var("ROS_DOMAIN_ID").map(|s| s.trim().to_string()) {
            None => 0,
            Some(s) if s.is_empty() => 0,
            Some(s) => match s.parse::<u16>() {
                Ok(d) if d <= 232 => d,
                _ => return Err(bad("ROS_DOMAIN_ID", &s, "expected an integer in 0..=232")),
            },
        };
        let range = match var("ROS_AUTOMATIC_DISCOVERY_RANGE")
            .map(|s| s.trim().to_ascii_uppercase())
            .filter(|s| !s.is_empty())
        {
            Some(s) => match s.as_str() {
                "LOCALHOST" => DiscoveryRange::Localhost,
                "SUBNET" | "SYSTEM_DEFAULT" => DiscoveryRange::Subnet,
                "OFF" => {
                    return Err(bad(
                        "ROS_AUTOMATIC_DISCOVERY_RANGE",
                        &s,
                        "OFF (static peers only) is not supported; use LOCALHOST or SUBNET",
                    ))
                }
                _ => {
                    return Err(bad(
                        "ROS_AUTOMATIC_DISCOVERY_RANGE",
                        &s,
                        "expected LOCALHOST, SUBNET or SYSTEM_DEFAULT",
                    ))
                }
            },
            None => match var("ROS_LOCALHOST_ONLY").map(|s| s.trim().to_string()) {
                Some(s) if s == "1" => DiscoveryRange::Localhost,
                Some(s) if s.is_empty() || s == "0" => DiscoveryRange::Subnet,
                None => DiscoveryRange::Subnet,
                Some(s) => return Err(bad("ROS_LOCALHOST_ONLY", &s, "expected 0 or 1")),
            },
        };
        Ok(Self { domain_id, range })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(pairs: &[(&str, &str)]) -> Result<RosEnv, NodeError> {
        let pairs: Vec<(String, String)> = pairs
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect();
        RosEnv::from_vars(move |k| pairs.iter().find(|p| p.0 == k).map(|p| p.1.clone()))
    }

    #[test]
    fn defaults_domain_0_on_the_subnet() {
        let e = env(&[]).unwrap();
        assert_eq!(e.domain_id, 0);
        assert_eq!(e.range, DiscoveryRange::Subnet);
    }

    #[test]
    fn domain_and_range_are_read_and_the_newer_variable_wins() {
        let e = env(&[("ROS_DOMAIN_ID", "42"), ("ROS_LOCALHOST_ONLY", "1")]).unwrap();
        assert_eq!((e.domain_id, e.range), (42, DiscoveryRange::Localhost));
        let e = env(&[
            ("ROS_LOCALHOST_ONLY", "1"),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "subnet"),
        ])
        .unwrap();
        assert_eq!(e.range, DiscoveryRange::Subnet);
    }

    #[test]
    fn bad_values_name_the_variable() {
        let e = env(&[("ROS_DOMAIN_ID", "300")]).unwrap_err().to_string();
        assert!(e.contains("ROS_DOMAIN_ID") && e.contains("300"), "{e}");
        let e = env(&[("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF")])
            .unwrap_err()
            .to_string();
        assert!(e.contains("OFF"), "{e}");
    }
}
