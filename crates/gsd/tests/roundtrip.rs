//! What the writer writes reads back through an independent reader of the specification
//! (header, name list, index sorted by frame then id, chunks), across index growth.

use std::io::Cursor;

use gsd::{GsdError, Writer};

/// A minimal GSD reader, from the file layer's specification.
struct File {
    bytes: Vec<u8>,
    names: Vec<String>,
    /// (frame, n, location, m, id, type)
    index: Vec<(u64, u64, u64, u32, u16, u8)>,
    application: String,
    schema: String,
    schema_version: u32,
    gsd_version: u32,
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}
fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}
fn text(b: &[u8]) -> String {
    String::from_utf8(b.iter().take_while(|&&c| c != 0).copied().collect()).unwrap()
}

impl File {
    fn read(bytes: Vec<u8>) -> File {
        assert_eq!(u64_at(&bytes, 0), 0x65DF_65DF_65DF_65DF);
        let (index_at, index_room) = (u64_at(&bytes, 8) as usize, u64_at(&bytes, 16) as usize);
        let (names_at, segments) = (u64_at(&bytes, 24) as usize, u64_at(&bytes, 32) as usize);
        let names: Vec<String> = bytes[names_at..names_at + 64 * segments]
            .split(|&c| c == 0)
            .take_while(|s| !s.is_empty())
            .map(|s| String::from_utf8(s.to_vec()).unwrap())
            .collect();
        let mut index = Vec::new();
        for k in 0..index_room {
            let e = &bytes[index_at + 32 * k..index_at + 32 * (k + 1)];
            let location = u64_at(e, 16);
            if location == 0 {
                break;
            }
            let entry = (
                u64_at(e, 0),
                u64_at(e, 8),
                location,
                u32_at(e, 24),
                u16::from_le_bytes([e[28], e[29]]),
                e[30],
            );
            assert_eq!(e[31], 0, "flags are reserved");
            assert!((entry.0 as usize) < index_room);
            index.push(entry);
        }
        File {
            application: text(&bytes[48..112]),
            schema: text(&bytes[112..176]),
            schema_version: u32_at(&bytes, 40),
            gsd_version: u32_at(&bytes, 44),
            bytes,
            names,
            index,
        }
    }

    fn frames(&self) -> u64 {
        self.index.last().map_or(0, |e| e.0 + 1)
    }

    /// The raw bytes, type and shape of chunk `name` in `frame`, found by binary search on
    /// (frame, id) as the reference reader of version 2 files does.
    fn chunk(&self, frame: u64, name: &str) -> Option<(&[u8], u8, u64, u32)> {
        let id = self.names.iter().position(|n| n == name)? as u16;
        let k = self
            .index
            .binary_search_by_key(&(frame, id), |e| (e.0, e.4))
            .ok()?;
        let (_, n, loc, m, _, ty) = self.index[k];
        let size = match ty {
            1 | 5 | 11 => 1,
            2 | 6 => 2,
            3 | 7 | 9 => 4,
            _ => 8,
        };
        let len = (n * u64::from(m)) as usize * size;
        Some((&self.bytes[loc as usize..loc as usize + len], ty, n, m))
    }

    fn f64s(&self, frame: u64, name: &str) -> Vec<f64> {
        let (b, ty, _, _) = self.chunk(frame, name).unwrap();
        assert_eq!(ty, 10);
        b.chunks(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }
}

#[test]
fn frames_read_back_through_index_growth() {
    let names = [
        "particles/position",
        "configuration/step",
        "particles/typeid",
    ];
    let mut w = Writer::create(Cursor::new(Vec::new()), "test", "hoomd", (1, 4), &names).unwrap();
    let frames = 300u64;
    for f in 0..frames {
        // Written in another order than the names: the index must still be sorted by id.
        w.write_chunk("particles/typeid", 2, 1, &[f as u32, 7])
            .unwrap();
        let x = f as f64;
        w.write_chunk("particles/position", 2, 3, &[x, 0.5, -x, 1.0, 2.0, 3.0])
            .unwrap();
        if f % 2 == 0 {
            w.write_chunk("configuration/step", 1, 1, &[10 * f])
                .unwrap();
        }
        w.end_frame().unwrap();
    }
    assert_eq!(w.frames(), frames);
    let file = File::read(w.into_inner().unwrap().into_inner());
    assert_eq!(file.names, names);
    assert_eq!(
        (file.application.as_str(), file.schema.as_str()),
        ("test", "hoomd")
    );
    assert_eq!(
        (file.schema_version, file.gsd_version),
        (0x0001_0004, 0x0002_0001)
    );
    assert_eq!(file.frames(), frames);
    let sorted = file
        .index
        .windows(2)
        .all(|w| (w[0].0, w[0].4) < (w[1].0, w[1].4));
    assert!(sorted, "index sorted by frame, then id");
    for f in [0, 1, 127, 128, 299] {
        let x = f as f64;
        assert_eq!(
            file.f64s(f, "particles/position"),
            vec![x, 0.5, -x, 1.0, 2.0, 3.0]
        );
        let (b, ty, n, m) = file.chunk(f, "particles/typeid").unwrap();
        assert_eq!((ty, n, m), (3, 2, 1));
        assert_eq!(u32_at(b, 0), f as u32);
        let step = file.chunk(f, "configuration/step");
        assert_eq!(step.is_some(), f % 2 == 0);
        if let Some((b, ty, ..)) = step {
            assert_eq!((ty, u64_at(b, 0)), (4, 10 * f));
        }
    }
}

#[test]
fn bad_chunks_are_refused() {
    let mut w = Writer::create(Cursor::new(Vec::new()), "t", "s", (1, 0), &["a"]).unwrap();
    assert!(matches!(
        w.write_chunk("b", 1, 1, &[1u8]),
        Err(GsdError::UnknownName(_))
    ));
    assert!(matches!(
        w.write_chunk("a", 2, 2, &[1u8; 3]),
        Err(GsdError::Shape { .. })
    ));
    w.write_chunk("a", 1, 1, &[1u8]).unwrap();
    assert!(matches!(
        w.write_chunk("a", 1, 1, &[1u8]),
        Err(GsdError::Twice(_))
    ));
    let long = "x".repeat(64);
    assert!(Writer::create(Cursor::new(Vec::new()), &long, "s", (1, 0), &["a"]).is_err());
}
