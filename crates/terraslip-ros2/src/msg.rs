//! ROS 2 message definitions (`ros2msg` text) and a CDR decoder driven by them.
//!
//! A definition is the text rosbag2 stores with a topic: the root message's
//! fields, then each dependency after a line of `=` and `MSG: pkg/Name`.
//! [`Registry`] parses it; [`Registry::decode`] turns one CDR message into a
//! [`Value`] tree whose struct fields are in definition order, so a field path
//! resolved once per topic ([`Registry::resolve`]) reads every message.

use std::collections::HashMap;

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

    /// Decodes one CDR-encapsulated message of type `root`.
    pub fn decode(&self, root: usize, data: &[u8]) -> Result<Value, String> {
        let mut c = Cursor::new(data)?;
        self.decode_msg(root, &mut c)
    }

    /// Decodes only the selected fields of one CDR message of type `root`;
    /// the others are skipped (bounds-checked) and stand as `UInt(0)`, so
    /// resolved paths stay valid.
    pub fn decode_selected(
        &self,
        root: usize,
        data: &[u8],
        sel: &Selection,
    ) -> Result<Value, String> {
        let mut c = Cursor::new(data)?;
        self.decode_msg_sel(root, &mut c, sel)
    }

    fn decode_msg_sel(&self, m: usize, c: &mut Cursor, sel: &Selection) -> Result<Value, String> {
        let def = &self.msgs[m];
        let mut out = Vec::with_capacity(def.fields.len());
        for (i, f) in def.fields.iter().enumerate() {
            let v = match (sel.child(i), &f.ty, f.arity) {
                (Some(s), Ty::Msg(j), Arity::One) if !s.children.is_empty() => {
                    self.decode_msg_sel(*j, c, s)?
                }
                (Some(_), _, _) => self.decode_field(f, c)?,
                (None, _, _) => {
                    self.skip_field(f, c)?;
                    Value::UInt(0)
                }
            };
            out.push(v);
        }
        Ok(Value::Struct(out))
    }

    fn skip_field(&self, f: &Field, c: &mut Cursor) -> Result<(), String> {
        let n = match f.arity {
            Arity::One => 1,
            Arity::Fixed(n) => n,
            Arity::Seq => c.u32()? as usize,
        };
        match f.ty {
            Ty::Prim(p @ (Prim::Str | Prim::WStr)) => {
                for _ in 0..n {
                    let len = c.u32()? as usize;
                    c.take(if p == Prim::Str {
                        len
                    } else {
                        len.saturating_mul(4)
                    })?;
                }
            }
            Ty::Prim(p) => {
                if n > 0 {
                    c.align(p.size());
                    c.take(n.saturating_mul(p.size()))?;
                }
            }
            Ty::Msg(j) => {
                if n > c.remaining() && !self.msgs[j].fields.is_empty() {
                    return Err(format!(
                        "field `{}`: {n} elements overrun the message",
                        f.name
                    ));
                }
                for _ in 0..n {
                    for g in &self.msgs[j].fields {
                        self.skip_field(g, c)?;
                    }
                }
            }
        }
        Ok(())
    }

    fn decode_field(&self, f: &Field, c: &mut Cursor) -> Result<Value, String> {
        match f.arity {
            Arity::One => match f.ty {
                Ty::Prim(p) => c.prim(p),
                Ty::Msg(i) => self.decode_msg(i, c),
            },
            Arity::Fixed(n) => self.decode_array(f, n, c),
            Arity::Seq => {
                let n = c.u32()? as usize;
                self.decode_array(f, n, c)
            }
        }
    }

    fn decode_msg(&self, m: usize, c: &mut Cursor) -> Result<Value, String> {
        let def = &self.msgs[m];
        let mut out = Vec::with_capacity(def.fields.len());
        for f in &def.fields {
            let v = self.decode_field(f, c)?;
            out.push(v);
        }
        Ok(Value::Struct(out))
    }

    fn decode_array(&self, f: &Field, n: usize, c: &mut Cursor) -> Result<Value, String> {
        match f.ty {
            Ty::Prim(Prim::U8) | Ty::Prim(Prim::I8) => Ok(Value::Bytes(c.take(n)?.to_vec())),
            Ty::Prim(Prim::Str) | Ty::Prim(Prim::WStr) => {
                let mut v = Vec::with_capacity(n.min(c.remaining() / 4));
                for _ in 0..n {
                    match c.prim(if f.ty == Ty::Prim(Prim::Str) {
                        Prim::Str
                    } else {
                        Prim::WStr
                    })? {
                        Value::Str(s) => v.push(s),
                        _ => unreachable!("strings decode to Str"),
                    }
                }
                Ok(Value::Strs(v))
            }
            Ty::Prim(p) => {
                if n.saturating_mul(p.size()) > c.remaining() {
                    return Err(format!(
                        "field `{}`: {n} elements overrun the message",
                        f.name
                    ));
                }
                let mut v = Vec::with_capacity(n);
                for _ in 0..n {
                    v.push(c.prim(p)?.as_f64().unwrap_or(f64::NAN));
                }
                Ok(Value::Nums(v))
            }
            Ty::Msg(i) => {
                // Each element takes at least one byte unless the type is empty.
                if n > c.remaining() && !self.msgs[i].fields.is_empty() {
                    return Err(format!(
                        "field `{}`: {n} elements overrun the message",
                        f.name
                    ));
                }
                let mut v = Vec::with_capacity(n.min(1 << 16));
                for _ in 0..n {
                    v.push(self.decode_msg(i, c)?);
                }
                Ok(Value::List(v))
            }
        }
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

struct Cursor<'a> {
    buf: &'a [u8],
    pos: usize,
    le: bool,
}

impl<'a> Cursor<'a> {
    /// After the 4-byte encapsulation header (CDR, little or big endian).
    fn new(data: &'a [u8]) -> Result<Self, String> {
        if data.len() < 4 {
            return Err(format!("{} bytes: shorter than the CDR header", data.len()));
        }
        let le = match data[1] {
            0x00 | 0x02 => false,
            0x01 | 0x03 => true,
            k => return Err(format!("unknown CDR encapsulation kind {k:#04x}")),
        };
        Ok(Self {
            buf: &data[4..],
            pos: 0,
            le,
        })
    }
    fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }
    fn align(&mut self, n: usize) {
        let p = self.pos.div_ceil(n) * n;
        self.pos = p.min(self.buf.len());
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if n > self.remaining() {
            return Err(format!(
                "message ends at byte {} where {n} more were expected",
                self.buf.len() + 4
            ));
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn fixed<const N: usize>(&mut self) -> Result<[u8; N], String> {
        self.align(N);
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N)?);
        if !self.le {
            a.reverse();
        }
        Ok(a)
    }
    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.fixed::<4>()?))
    }
    fn prim(&mut self, p: Prim) -> Result<Value, String> {
        Ok(match p {
            Prim::Bool => Value::Bool(self.take(1)?[0] != 0),
            Prim::I8 => Value::Int(self.take(1)?[0] as i8 as i64),
            Prim::U8 => Value::UInt(self.take(1)?[0] as u64),
            Prim::I16 => Value::Int(i16::from_le_bytes(self.fixed()?) as i64),
            Prim::U16 => Value::UInt(u16::from_le_bytes(self.fixed()?) as u64),
            Prim::I32 => Value::Int(i32::from_le_bytes(self.fixed()?) as i64),
            Prim::U32 => Value::UInt(u32::from_le_bytes(self.fixed()?) as u64),
            Prim::I64 => Value::Int(i64::from_le_bytes(self.fixed()?)),
            Prim::U64 => Value::UInt(u64::from_le_bytes(self.fixed()?)),
            Prim::F32 => Value::Float(f32::from_le_bytes(self.fixed()?) as f64),
            Prim::F64 => Value::Float(f64::from_le_bytes(self.fixed()?)),
            Prim::Str => {
                let n = self.u32()? as usize;
                let b = self.take(n)?;
                let b = b.strip_suffix(&[0]).unwrap_or(b);
                Value::Str(String::from_utf8_lossy(b).into_owned())
            }
            Prim::WStr => {
                let n = self.u32()? as usize;
                let b = self.take(n.saturating_mul(4))?;
                let s: String = b
                    .chunks_exact(4)
                    .filter_map(|c| {
                        let mut a = [c[0], c[1], c[2], c[3]];
                        if !self.le {
                            a.reverse();
                        }
                        char::from_u32(u32::from_le_bytes(a))
                    })
                    .filter(|&c| c != '\0')
                    .collect();
                Value::Str(s)
            }
        })
    }
}

/// Writes little-endian CDR (the encoding rosbag2 records).
#[derive(Debug, Default)]
pub struct CdrWriter {
    buf: Vec<u8>,
}

impl CdrWriter {
    /// Starts a message with the CDR_LE encapsulation header.
    pub fn new() -> Self {
        Self {
            buf: vec![0, 1, 0, 0],
        }
    }
    fn align(&mut self, n: usize) {
        while !(self.buf.len() - 4).is_multiple_of(n) {
            self.buf.push(0);
        }
    }
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.buf.push(v);
        self
    }
    pub fn i32(&mut self, v: i32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }
    pub fn string(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32 + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
        self
    }
    /// `builtin_interfaces/Time` from nanoseconds since the epoch.
    pub fn time(&mut self, ns: u64) -> &mut Self {
        self.i32((ns / 1_000_000_000) as i32)
            .u32((ns % 1_000_000_000) as u32)
    }
    /// `std_msgs/Header`.
    pub fn header(&mut self, ns: u64, frame: &str) -> &mut Self {
        self.time(ns).string(frame)
    }
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }
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
