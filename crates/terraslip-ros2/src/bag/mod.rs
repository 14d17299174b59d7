//! Opening a rosbag2 recording and streaming its raw messages.
//!
//! A bag is a directory with `metadata.yaml` (versions 4 to 9) naming its
//! storage files, a directory of storage files without it (a recording that
//! was not closed, or copied without it), or one `.mcap` / `.db3` file
//! (optionally `.zstd`/`.lz4` compressed whole). Messages are streamed file by file; memory holds one
//! MCAP chunk or one sqlite row at a time.

mod files;
mod reader;
mod stream;
mod tables;

pub use files::is_bag;
pub use reader::{Bag, HeldMessage, RawMessage, Topic};
