//! A writer of GSD files ("general simulation data", the format of HOOMD-blue that the `gsd`
//! Python package and OVITO read), written from the file layer's specification (version 2.x,
//! `doc/file-layer.rst` of glotzerlab/gsd), not from its code. It knows chunks, not physics: what
//! the chunks mean is the schema's business (the `hoomd` schema, in `sweep edmd --trajectory`).
//!
//! Layout, all integers little-endian:
//! - a 256-byte header: magic `0x65DF65DF65DF65DF`, where the index and the name list are and how
//!   many entries each has room for, the schema's version, the file layer's (2.1), and the
//!   application's and schema's names (64 bytes each, 0-padded);
//! - the name list: every chunk name, 0-terminated, in a block of 64-byte segments; an entry's
//!   `id` is its name's position. All names are given when the file is created (a fixed set per
//!   trajectory), so the block is written once;
//! - the index: 32-byte entries (frame, N, location, M, id, type, flags) sorted by frame, then
//!   id; the first entry with location 0 ends it. When it is full, a block twice as large is
//!   written at the end of the file and the header points there;
//! - the data chunks, N×M elements each, row-major.
//!
//! A frame's chunks are written before its index entries, and the entries before the header
//! that counts them: a writer killed mid-frame leaves a file whose earlier frames read back.

use std::io::{Seek, SeekFrom, Write};

/// The file layer version written: 2.1 (`0xaaaabbbb` = aaaa.bbbb).
const GSD_VERSION: u32 = (2 << 16) | 1;
const MAGIC: u64 = 0x65DF_65DF_65DF_65DF;
const HEADER_BYTES: u64 = 256;
const ENTRY_BYTES: u64 = 32;
/// Names are allocated in segments of this many bytes.
const NAME_SEGMENT: usize = 64;
/// Room in the first index block (the reference implementation's initial size).
const INITIAL_INDEX: u64 = 128;

/// The element types of the specification, with their codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Type {
    U8 = 1,
    U16 = 2,
    U32 = 3,
    U64 = 4,
    I8 = 5,
    I16 = 6,
    I32 = 7,
    I64 = 8,
    F32 = 9,
    F64 = 10,
    /// UTF-8 text (file layer 2.1).
    Char = 11,
}

/// A value that can be an element of a chunk.
pub trait Element: Copy {
    const TYPE: Type;
    /// Appends the little-endian bytes of `self`.
    fn put(self, out: &mut Vec<u8>);
}

macro_rules! element {
    ($t:ty, $code:expr) => {
        impl Element for $t {
            const TYPE: Type = $code;
            fn put(self, out: &mut Vec<u8>) {
                out.extend_from_slice(&self.to_le_bytes());
            }
        }
    };
}
element!(u8, Type::U8);
element!(u32, Type::U32);
element!(u64, Type::U64);
element!(i8, Type::I8);
element!(i32, Type::I32);
element!(f32, Type::F32);
element!(f64, Type::F64);

#[derive(Debug, thiserror::Error)]
pub enum GsdError {
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error("chunk `{0}` was not named when the file was created")]
    UnknownName(String),
    #[error("chunk `{name}`: {len} elements for {n}×{m}")]
    Shape {
        name: String,
        len: usize,
        n: u64,
        m: u32,
    },
    #[error("chunk `{0}` written twice in one frame")]
    Twice(String),
    #[error("{what} `{text}` is longer than 63 bytes")]
    TooLong { what: &'static str, text: String },
    #[error("more than 65535 chunk names")]
    TooManyNames,
}

/// An index entry (the specification's `gsd_index_entry`).
#[derive(Clone, Copy, Debug)]
struct Entry {
    frame: u64,
    n: u64,
    location: u64,
    m: u32,
    id: u16,
    kind: Type,
}

impl Entry {
    fn bytes(&self) -> [u8; ENTRY_BYTES as usize] {
        let mut b = [0u8; ENTRY_BYTES as usize];
        b[0..8].copy_from_slice(&self.frame.to_le_bytes());
        b[8..16].copy_from_slice(&self.n.to_le_bytes());
        b[16..24].copy_from_slice(&self.location.to_le_bytes());
        b[24..28].copy_from_slice(&self.m.to_le_bytes());
        b[28..30].copy_from_slice(&self.id.to_le_bytes());
        b[30] = self.kind as u8;
        // b[31]: flags, reserved (0).
        b
    }
}

/// Writes frames of named chunks to `w` (a file, or a buffer in tests).
pub struct Writer<W: Write + Seek> {
    w: W,
    names: Vec<String>,
    application: String,
    schema: String,
    schema_version: u32,
    namelist_location: u64,
    namelist_segments: u64,
    index_location: u64,
    index_room: u64,
    /// The entries already in the index, kept to copy them when it grows.
    index: Vec<Entry>,
    /// The frame being written, and its entries so far.
    frame: u64,
    pending: Vec<Entry>,
    /// Where the next chunk goes: the end of the file.
    end: u64,
    scratch: Vec<u8>,
}

impl<W: Write + Seek> Writer<W> {
    /// A new file on `w` (written from its start) for chunks named `names`; `schema_version`
    /// is (major, minor).
    pub fn create(
        w: W,
        application: &str,
        schema: &str,
        schema_version: (u16, u16),
        names: &[&str],
    ) -> Result<Self, GsdError> {
        for (what, text) in [("application", application), ("schema", schema)] {
            if text.len() > 63 {
                return Err(GsdError::TooLong {
                    what,
                    text: text.into(),
                });
            }
        }
        if names.len() >= usize::from(u16::MAX) {
            return Err(GsdError::TooManyNames);
        }
        let mut list: Vec<u8> = names.iter().flat_map(|n| n.bytes().chain([0])).collect();
        // A name starting with 0 ends the list: at least one more 0, then whole segments.
        list.push(0);
        list.resize(list.len().div_ceil(NAME_SEGMENT) * NAME_SEGMENT, 0);
        let namelist_location = HEADER_BYTES;
        let index_location = namelist_location + list.len() as u64;
        let mut writer = Writer {
            w,
            names: names.iter().map(|n| n.to_string()).collect(),
            application: application.into(),
            schema: schema.into(),
            schema_version: (u32::from(schema_version.0) << 16) | u32::from(schema_version.1),
            namelist_location,
            namelist_segments: (list.len() / NAME_SEGMENT) as u64,
            index_location,
            index_room: INITIAL_INDEX,
            index: Vec::new(),
            frame: 0,
            pending: Vec::new(),
            end: index_location + INITIAL_INDEX * ENTRY_BYTES,
            scratch: Vec::new(),
        };
        writer.w.seek(SeekFrom::Start(0))?;
        writer.write_header()?;
        writer.w.write_all(&list)?;
        writer
            .w
            .write_all(&vec![0u8; (INITIAL_INDEX * ENTRY_BYTES) as usize])?;
        writer.w.flush()?;
        Ok(writer)
    }

    fn write_header(&mut self) -> Result<(), GsdError> {
        let mut h = Vec::with_capacity(HEADER_BYTES as usize);
        for x in [
            MAGIC,
            self.index_location,
            self.index_room,
            self.namelist_location,
            self.namelist_segments,
        ] {
            h.extend_from_slice(&x.to_le_bytes());
        }
        h.extend_from_slice(&self.schema_version.to_le_bytes());
        h.extend_from_slice(&GSD_VERSION.to_le_bytes());
        for text in [&self.application, &self.schema] {
            let mut field = [0u8; 64];
            field[..text.len()].copy_from_slice(text.as_bytes());
            h.extend_from_slice(&field);
        }
        h.resize(HEADER_BYTES as usize, 0);
        self.w.seek(SeekFrom::Start(0))?;
        self.w.write_all(&h)?;
        Ok(())
    }

    /// Writes chunk `name` of the present frame: `n` rows of `m` elements, row-major.
    pub fn write_chunk<T: Element>(
        &mut self,
        name: &str,
        n: u64,
        m: u32,
        data: &[T],
    ) -> Result<(), GsdError> {
        let id = self
            .names
            .iter()
            .position(|x| x == name)
            .ok_or_else(|| GsdError::UnknownName(name.into()))? as u16;
        if m == 0 || data.len() as u64 != n * u64::from(m) {
            return Err(GsdError::Shape {
                name: name.into(),
                len: data.len(),
                n,
                m,
            });
        }
        if self.pending.iter().any(|e| e.id == id) {
            return Err(GsdError::Twice(name.into()));
        }
        self.scratch.clear();
        for &x in data {
            x.put(&mut self.scratch);
        }
        self.w.seek(SeekFrom::Start(self.end))?;
        self.w.write_all(&self.scratch)?;
        self.pending.push(Entry {
            frame: self.frame,
            n,
            location: self.end,
            m,
            id,
            kind: T::TYPE,
        });
        self.end += self.scratch.len() as u64;
        Ok(())
    }

    /// Commits the present frame: its index entries (sorted by name id, as version 2 requires),
    /// a larger index block first if they do not fit, then the data reaches the sink.
    pub fn end_frame(&mut self) -> Result<(), GsdError> {
        self.pending.sort_by_key(|e| e.id);
        let written = self.index.len() as u64;
        let needed = written + self.pending.len() as u64;
        if needed > self.index_room {
            self.grow_index(needed)?;
        }
        let mut bytes = Vec::with_capacity(self.pending.len() * ENTRY_BYTES as usize);
        for e in &self.pending {
            bytes.extend_from_slice(&e.bytes());
        }
        self.w
            .seek(SeekFrom::Start(self.index_location + written * ENTRY_BYTES))?;
        self.w.write_all(&bytes)?;
        self.index.append(&mut self.pending);
        self.frame += 1;
        self.w.flush()?;
        Ok(())
    }

    /// Copies the index into a block at the end of the file with room for at least `needed`
    /// entries, and points the header there.
    fn grow_index(&mut self, needed: u64) -> Result<(), GsdError> {
        let room = (2 * self.index_room).max(needed);
        let mut block = Vec::with_capacity((room * ENTRY_BYTES) as usize);
        for e in &self.index {
            block.extend_from_slice(&e.bytes());
        }
        block.resize((room * ENTRY_BYTES) as usize, 0);
        self.w.seek(SeekFrom::Start(self.end))?;
        self.w.write_all(&block)?;
        self.index_location = self.end;
        self.index_room = room;
        self.end += block.len() as u64;
        self.write_header()
    }

    /// Frames committed so far.
    pub fn frames(&self) -> u64 {
        self.frame
    }

    /// The sink, flushed.
    pub fn into_inner(mut self) -> Result<W, GsdError> {
        self.w.flush()?;
        Ok(self.w)
    }
}
