//! Decoding CDR messages with a [`Registry`]'s definitions: all fields, or
//! a [`Selection`] of them with the rest skipped (bounds-checked).

use super::{Arity, Field, Prim, Registry, Selection, Ty, Value};

impl Registry {
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
