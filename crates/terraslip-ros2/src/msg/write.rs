//! Writing CDR messages.

/// Writes little-endian CDR (the encoding rosbag2 records).
#[derive(Debug, Default)]
pub struct CdrWriter {
    pub(super) buf: Vec<u8>,
}

impl CdrWriter {
    /// Starts a message with the CDR_LE encapsulation header.
    pub fn new() -> Self {
        Self {
            buf: vec![0, 1, 0, 0],
        }
    }
    pub(super) fn align(&mut self, n: usize) {
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
