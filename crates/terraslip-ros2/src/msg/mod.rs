//! ROS 2 message definitions (`ros2msg` text) and a CDR decoder driven by them.
//!
//! A definition is the text rosbag2 stores with a topic: the root message's
//! fields, then each dependency after a line of `=` and `MSG: pkg/Name`.
//! [`Registry`] parses it; [`Registry::decode`] turns one CDR message into a
//! [`Value`] tree whose struct fields are in definition order, so a field path
//! resolved once per topic ([`Registry::resolve`]) reads every message.
//!
//! Parsing lives in `parse`, decoding in `decode`, the [`CdrWriter`] in `write`.

use std::collections::HashMap;

pub mod build;
mod decode;
mod parse;
mod write;

pub use write::CdrWriter;

/// A primitive ROS 2 type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Prim {
    Bool,
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
    Str,
    WStr,
}

impl Prim {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "bool" => Prim::Bool,
            "byte" | "uint8" | "char" => Prim::U8,
            "int8" => Prim::I8,
            "int16" => Prim::I16,
            "uint16" => Prim::U16,
            "int32" => Prim::I32,
            "uint32" => Prim::U32,
            "int64" => Prim::I64,
            "uint64" => Prim::U64,
            "float32" => Prim::F32,
            "float64" => Prim::F64,
            _ if s == "string" || s.starts_with("string<=") => Prim::Str,
            _ if s == "wstring" || s.starts_with("wstring<=") => Prim::WStr,
            _ => return None,
        })
    }
    /// Size (and CDR alignment) in bytes; strings align as their u32 length.
    fn size(self) -> usize {
        match self {
            Prim::Bool | Prim::I8 | Prim::U8 => 1,
            Prim::I16 | Prim::U16 => 2,
            Prim::I32 | Prim::U32 | Prim::F32 | Prim::Str | Prim::WStr => 4,
            Prim::I64 | Prim::U64 | Prim::F64 => 8,
        }
    }
}

/// The element type of a field.
#[derive(Debug, Clone, PartialEq)]
pub enum Ty {
    Prim(Prim),
    /// Index into the registry's message list.
    Msg(usize),
}

/// Whether a field is one value, a fixed array or a sequence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arity {
    One,
    Fixed(usize),
    /// `T[]` or `T[<=N]`: a u32 length first.
    Seq,
}

/// One field of a message.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    pub name: String,
    pub ty: Ty,
    pub arity: Arity,
}

/// One message type.
#[derive(Debug, Clone, PartialEq)]
pub struct MsgDef {
    /// `pkg/Name` (the `msg/` part dropped).
    pub name: String,
    pub fields: Vec<Field>,
}

/// A decoded value. Arrays of numbers decode to [`Value::Nums`] (as f64),
/// byte arrays to [`Value::Bytes`].
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Bool(bool),
    Int(i64),
    UInt(u64),
    Float(f64),
    Str(String),
    Bytes(Vec<u8>),
    Nums(Vec<f64>),
    Strs(Vec<String>),
    List(Vec<Value>),
    Struct(Vec<Value>),
}

impl Value {
    /// The value as f64 (numbers and bools).
    pub fn as_f64(&self) -> Option<f64> {
        match *self {
            Value::Float(x) => Some(x),
            Value::Int(i) => Some(i as f64),
            Value::UInt(u) => Some(u as f64),
            Value::Bool(b) => Some(b as u8 as f64),
            _ => None,
        }
    }
    /// The value at a resolved path of struct field indices.
    pub fn at(&self, path: &[usize]) -> Option<&Value> {
        let mut v = self;
        for &i in path {
            match v {
                Value::Struct(f) => v = f.get(i)?,
                _ => return None,
            }
        }
        Some(v)
    }
    pub fn f64_at(&self, path: &[usize]) -> Option<f64> {
        self.at(path)?.as_f64()
    }
}

/// Which fields [`Registry::decode_selected`] decodes: a trie of resolved
/// field paths. A path's last field is decoded whole.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Selection {
    children: Vec<(usize, Selection)>,
}

impl Selection {
    /// Adds a path from [`Registry::resolve`].
    pub fn add(&mut self, path: &[usize]) {
        let Some((&first, rest)) = path.split_first() else {
            return;
        };
        match self.children.iter_mut().find(|(i, _)| *i == first) {
            // A field asked for whole stays whole; a shorter path makes it whole.
            Some((_, child)) if rest.is_empty() => child.children.clear(),
            Some((_, child)) if !child.children.is_empty() => child.add(rest),
            Some(_) => {}
            None => {
                let mut child = Selection::default();
                child.add(rest);
                self.children.push((first, child));
            }
        }
    }
    fn child(&self, i: usize) -> Option<&Selection> {
        self.children.iter().find(|(j, _)| *j == i).map(|(_, s)| s)
    }
}

/// Normalises `pkg/msg/Name` to `pkg/Name`.
pub fn short_type(name: &str) -> String {
    let parts: Vec<&str> = name.split('/').collect();
    match parts.as_slice() {
        [pkg, "msg", n] => format!("{pkg}/{n}"),
        _ => name.to_string(),
    }
}

/// Parsed message definitions, by type name.
#[derive(Debug, Clone, Default)]
pub struct Registry {
    pub msgs: Vec<MsgDef>,
    by_name: HashMap<String, usize>,
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEF: &str = "std_msgs/Header header\nstring[] name\nfloat64[] velocity\nuint8 K=3 # a constant\nfloat32[2] pair\n\
================\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
================\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";

    /// A `DEF` message: stamp 3.5 s, joints left/right at 1.5 and -2.0, pair (0.25, 4).
    fn sample() -> Vec<u8> {
        let mut w = CdrWriter::new();
        w.header(3_500_000_000, "base_link");
        w.u32(2).string("left").string("right");
        w.u32(2).f64(1.5).f64(-2.0);
        w.align(4);
        w.buf.extend_from_slice(&0.25f32.to_le_bytes());
        w.buf.extend_from_slice(&4.0f32.to_le_bytes());
        w.finish()
    }

    #[test]
    fn decodes_what_the_writer_wrote() {
        let (reg, root) = Registry::parse("sensor_msgs/msg/Thing", DEF, None).unwrap();
        let v = reg.decode(root, &sample()).unwrap();
        let sec = reg.resolve(root, "header.stamp.sec").unwrap();
        let ns = reg.resolve(root, "header.stamp.nanosec").unwrap();
        assert_eq!(v.f64_at(&sec), Some(3.0));
        assert_eq!(v.f64_at(&ns), Some(5e8));
        let vel = reg.resolve(root, "velocity").unwrap();
        assert_eq!(v.at(&vel), Some(&Value::Nums(vec![1.5, -2.0])));
        let names = reg.resolve(root, "name").unwrap();
        assert_eq!(
            v.at(&names),
            Some(&Value::Strs(vec!["left".into(), "right".into()]))
        );
        assert_eq!(
            v.at(&reg.resolve(root, "pair").unwrap()),
            Some(&Value::Nums(vec![0.25, 4.0]))
        );
        assert!(reg.resolve(root, "header.nope").is_none());
    }

    #[test]
    fn selected_decoding_reads_the_same_fields() {
        let (reg, root) = Registry::parse("sensor_msgs/msg/Thing", DEF, None).unwrap();
        let data = sample();
        let full = reg.decode(root, &data).unwrap();
        let mut sel = Selection::default();
        let ns = reg.resolve(root, "header.stamp.nanosec").unwrap();
        let pair = reg.resolve(root, "pair").unwrap();
        sel.add(&ns);
        sel.add(&pair);
        let part = reg.decode_selected(root, &data, &sel).unwrap();
        assert_eq!(part.at(&ns), full.at(&ns));
        assert_eq!(part.at(&pair), full.at(&pair));
        assert_eq!(
            part.at(&reg.resolve(root, "velocity").unwrap()),
            Some(&Value::UInt(0))
        );
        for n in 0..data.len() {
            assert!(
                reg.decode_selected(root, &data[..n], &sel).is_err(),
                "prefix {n}"
            );
        }
    }

    #[test]
    fn truncated_and_hostile_input_is_an_error() {
        let (reg, root) = Registry::parse("sensor_msgs/Thing", DEF, None).unwrap();
        let mut w = CdrWriter::new();
        w.header(1, "x").u32(0x7fff_ffff);
        let data = w.finish();
        assert!(reg.decode(root, &data).is_err());
        for n in 0..data.len() {
            assert!(reg.decode(root, &data[..n]).is_err(), "prefix {n}");
        }
    }

    #[test]
    fn an_empty_definition_takes_the_builtin_one() {
        let (reg, root) =
            Registry::parse("nav_msgs/msg/Odometry", "", Some(crate::defs::BUILTIN)).unwrap();
        assert!(reg.resolve(root, "twist.twist.linear.x").is_some());
        assert!(Registry::parse("nav_msgs/msg/Path", "", Some(crate::defs::BUILTIN)).is_err());
    }

    #[test]
    fn missing_dependency_is_named() {
        let e = Registry::parse("a/B", "c/D d\n", None).unwrap_err();
        assert!(e.contains("c/D"), "{e}");
    }
}
