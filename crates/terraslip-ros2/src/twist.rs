//! `geometry_msgs/Twist` and `geometry_msgs/TwistStamped`: the velocity
//! commands a drive controller takes (body frame, REP-103: linear m/s,
//! angular rad/s), read from and written to CDR.

use crate::defs::BUILTIN;
use crate::msg::{CdrWriter, Registry};

/// The unstamped command type.
pub const TWIST_TYPE: &str = "geometry_msgs/msg/Twist";
/// The stamped command type.
pub const TWIST_STAMPED_TYPE: &str = "geometry_msgs/msg/TwistStamped";

/// One velocity command.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TwistMsg {
    /// Header stamp, ns since the epoch (stamped commands only).
    pub stamp_ns: Option<u64>,
    /// Header frame (stamped commands only; empty otherwise).
    pub frame: String,
    /// Linear velocity x, y, z, m/s.
    pub linear: [f64; 3],
    /// Angular velocity x, y, z, rad/s.
    pub angular: [f64; 3],
}

/// Reads and writes one of the two command types.
#[derive(Debug, Clone)]
pub struct TwistCodec {
    stamped: bool,
    reg: Registry,
    root: usize,
    /// Paths of linear x, y, z then angular x, y, z.
    paths: Vec<Vec<usize>>,
}

const FIELDS: [&str; 6] = [
    "linear.x",
    "linear.y",
    "linear.z",
    "angular.x",
    "angular.y",
    "angular.z",
];

impl TwistCodec {
    /// The codec of `TwistStamped` (`stamped`) or `Twist`.
    pub fn new(stamped: bool) -> Self {
        let ty = if stamped {
            TWIST_STAMPED_TYPE
        } else {
            TWIST_TYPE
        };
        let (reg, root) = Registry::parse(ty, "", Some(BUILTIN)).expect("built-in definition");
        let prefix = if stamped { "twist." } else { "" };
        let paths = FIELDS
            .iter()
            .map(|f| {
                reg.resolve(root, &format!("{prefix}{f}"))
                    .expect("built-in field")
            })
            .collect();
        Self {
            stamped,
            reg,
            root,
            paths,
        }
    }

    /// The ROS type this codec reads and writes.
    pub fn ty(&self) -> &'static str {
        if self.stamped {
            TWIST_STAMPED_TYPE
        } else {
            TWIST_TYPE
        }
    }

    /// Decodes one CDR-encapsulated message (either byte order).
    pub fn decode(&self, data: &[u8]) -> Result<TwistMsg, String> {
        let v = self.reg.decode(self.root, data)?;
        let mut out = TwistMsg::default();
        for (k, p) in self.paths.iter().enumerate() {
            let x = v
                .f64_at(p)
                .ok_or_else(|| format!("{}: no {}", self.ty(), FIELDS[k]))?;
            if k < 3 {
                out.linear[k] = x;
            } else {
                out.angular[k - 3] = x;
            }
        }
        if self.stamped {
            let sec = v.f64_at(&[0, 0, 0]).unwrap_or(0.0);
            let nsec = v.f64_at(&[0, 0, 1]).unwrap_or(0.0);
            out.stamp_ns = Some((sec.max(0.0) as u64) * 1_000_000_000 + nsec.max(0.0) as u64);
            if let Some(crate::msg::Value::Str(f)) = v.at(&[0, 1]) {
                out.frame = f.clone();
            }
        }
        Ok(out)
    }

    /// Encodes `m` (little-endian CDR); an unstamped codec drops the
    /// header, a stamped one writes stamp 0 when `m` has none.
    pub fn encode(&self, m: &TwistMsg) -> Vec<u8> {
        let mut w = CdrWriter::new();
        if self.stamped {
            w.header(m.stamp_ns.unwrap_or(0), &m.frame);
        }
        for x in m.linear.iter().chain(m.angular.iter()) {
            w.f64(*x);
        }
        w.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_types_round_trip() {
        let m = TwistMsg {
            stamp_ns: Some(1_700_000_000_123_456_789),
            frame: "base_link".into(),
            linear: [0.5, -0.1, 0.0],
            angular: [0.0, 0.0, -0.25],
        };
        let stamped = TwistCodec::new(true);
        let data = stamped.encode(&m);
        assert_eq!(stamped.decode(&data).unwrap(), m);
        let plain = TwistCodec::new(false);
        let data = plain.encode(&m);
        // Header, 6 doubles: 4 + 48 bytes.
        assert_eq!(data.len(), 52);
        let back = plain.decode(&data).unwrap();
        assert_eq!((back.linear, back.angular), (m.linear, m.angular));
        assert_eq!((back.stamp_ns, back.frame.as_str()), (None, ""));
        // Big-endian input (another DDS's choice) reads the same.
        let mut be = vec![0u8, 0, 0, 0];
        for x in m.linear.iter().chain(m.angular.iter()) {
            be.extend_from_slice(&x.to_be_bytes());
        }
        assert_eq!(plain.decode(&be).unwrap().angular, m.angular);
        // A short message is an error, not a panic.
        assert!(plain.decode(&data[..30]).is_err());
        assert!(stamped.decode(&data).is_err());
    }
}
