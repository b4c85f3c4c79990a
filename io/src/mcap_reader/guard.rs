//! A [`Read`] adapter that checks the MCAP record framing before the `mcap` reader sees the
//! bytes: every record inside an uncompressed chunk must fit in the chunk.
//!
//! `mcap` 0.26.0's `LinearReader` subtracts an uncompressed chunk's record lengths from the
//! chunk's remaining bytes unchecked (a panic with overflow checks, a read past the chunk in
//! release). A compressed chunk is bounded by its decompressor and passes unexamined. The
//! guard hands bytes on only once the framing they belong to was checked, so the reader
//! never holds a record header the guard has not seen; it looks ahead at most one chunk
//! header (40 bytes) and keeps one read's worth of bytes.

use std::io::{self, Read};

use mcap::records::op;

use super::READ_BYTES;
/// The magic at the start of a file.
const MAGIC_BYTES: u64 = 8;
/// A record's opcode and u64 length.
const RECORD_HEADER_BYTES: usize = 9;
/// A chunk header with an empty compression string: start and end times, uncompressed size,
/// uncompressed CRC, the compression string's u32 length, compressed size.
const CHUNK_HEADER_BYTES: usize = 40;
/// Where the compression string's length and (when it is empty) the compressed size lie in
/// a chunk header.
const COMPRESSION_LEN_AT: usize = 28;
const COMPRESSED_SIZE_AT: usize = 32;

/// Where the framing walk stands; `left` counts bytes still to pass in the current part.
#[derive(Debug, Clone, Copy)]
enum State {
    Magic {
        left: u64,
    },
    RecordHeader,
    Body {
        left: u64,
    },
    ChunkHeader {
        len: u64,
    },
    ChunkRecord {
        left: u64,
        padding: u64,
    },
    ChunkBody {
        left: u64,
        chunk_left: u64,
        padding: u64,
    },
    /// The footer and the end magic: nothing after them is framed.
    Rest,
}

/// The source, with the framing checked ahead of the reader (module documentation).
pub(crate) struct ChunkGuard<R> {
    source: R,
    /// Bytes read from the source and not yet handed on.
    buf: Vec<u8>,
    /// `buf[..start]` were handed on.
    start: usize,
    /// `buf[start..checked]` are checked and may be handed on.
    checked: usize,
    /// The stream offset of `buf[checked]`.
    offset: u64,
    state: State,
    eof: bool,
    refusal: Option<String>,
}

impl<R: Read> ChunkGuard<R> {
    pub(crate) fn new(source: R) -> Self {
        Self {
            source,
            buf: Vec::new(),
            start: 0,
            checked: 0,
            offset: 0,
            state: State::Magic { left: MAGIC_BYTES },
            eof: false,
            refusal: None,
        }
    }

    /// Why the stream was refused, once (the read that failed returned `InvalidData`).
    pub(crate) fn take_refusal(&mut self) -> Option<String> {
        self.refusal.take()
    }

    /// Advances the walk over the bytes read: `Ok(false)` when it needs more of them.
    fn step(&mut self) -> Result<bool, String> {
        let avail = &self.buf[self.checked..];
        let at = self.offset;
        let (pass, next) = match self.state {
            State::Magic { left } | State::Body { left } => {
                let n = left.min(avail.len() as u64);
                if n == 0 && left > 0 {
                    return Ok(false);
                }
                let next = if n == left {
                    State::RecordHeader
                } else {
                    State::Body { left: left - n }
                };
                (n, next)
            }
            State::ChunkBody {
                left,
                chunk_left,
                padding,
            } => {
                let n = left.min(avail.len() as u64);
                if n == 0 && left > 0 {
                    return Ok(false);
                }
                let next = if n == left {
                    State::ChunkRecord {
                        left: chunk_left,
                        padding,
                    }
                } else {
                    State::ChunkBody {
                        left: left - n,
                        chunk_left,
                        padding,
                    }
                };
                (n, next)
            }
            State::Rest if avail.is_empty() => return Ok(false),
            State::Rest => (avail.len() as u64, State::Rest),
            State::RecordHeader => {
                let Some(header) = avail.get(..RECORD_HEADER_BYTES) else {
                    return Ok(false);
                };
                let len = u64_at(header, 1);
                let next = match header[0] {
                    op::CHUNK => State::ChunkHeader { len },
                    op::FOOTER => State::Rest,
                    _ => State::Body { left: len },
                };
                (RECORD_HEADER_BYTES as u64, next)
            }
            State::ChunkHeader { len } => {
                if len < CHUNK_HEADER_BYTES as u64 {
                    return Err(format!(
                        "the chunk at byte {} holds {len} bytes, fewer than a chunk header's {CHUNK_HEADER_BYTES}",
                        at.saturating_sub(RECORD_HEADER_BYTES as u64)
                    ));
                }
                let Some(header) = avail.get(..CHUNK_HEADER_BYTES) else {
                    return Ok(false);
                };
                let compression_len = u32::from_le_bytes([
                    header[COMPRESSION_LEN_AT],
                    header[COMPRESSION_LEN_AT + 1],
                    header[COMPRESSION_LEN_AT + 2],
                    header[COMPRESSION_LEN_AT + 3],
                ]);
                if compression_len != 0 {
                    // Compressed: the decompressor bounds its records.
                    (0, State::Body { left: len })
                } else {
                    let records = u64_at(header, COMPRESSED_SIZE_AT);
                    let room = len - CHUNK_HEADER_BYTES as u64;
                    if records > room {
                        return Err(format!(
                            "the chunk at byte {} declares {records} bytes of records but holds {room}",
                            at.saturating_sub(RECORD_HEADER_BYTES as u64)
                        ));
                    }
                    let next = State::ChunkRecord {
                        left: records,
                        padding: room - records,
                    };
                    (CHUNK_HEADER_BYTES as u64, next)
                }
            }
            State::ChunkRecord { left, padding } => {
                if left == 0 {
                    (0, State::Body { left: padding })
                } else if left < RECORD_HEADER_BYTES as u64 {
                    return Err(format!(
                        "an uncompressed chunk ends {left} bytes into a record header at byte {at}"
                    ));
                } else {
                    let Some(header) = avail.get(..RECORD_HEADER_BYTES) else {
                        return Ok(false);
                    };
                    let len = u64_at(header, 1);
                    let room = left - RECORD_HEADER_BYTES as u64;
                    if len > room {
                        return Err(format!(
                            "the record at byte {at} declares {len} bytes but its uncompressed chunk holds {room} more"
                        ));
                    }
                    let next = State::ChunkBody {
                        left: len,
                        chunk_left: room - len,
                        padding,
                    };
                    (RECORD_HEADER_BYTES as u64, next)
                }
            }
        };
        // `pass` is at most `avail.len()` (a header's size only once it was there); a step
        // that passes nothing changes the state, so every `Ok(true)` is progress.
        self.checked += pass as usize;
        self.offset += pass;
        self.state = next;
        Ok(true)
    }

    /// Reads more of the source behind the bytes not yet handed on (sets `eof` at its end).
    fn fill(&mut self) -> io::Result<()> {
        self.buf.drain(..self.start);
        self.checked -= self.start;
        self.start = 0;
        let old = self.buf.len();
        self.buf.resize(old + READ_BYTES, 0);
        let read = self.source.read(&mut self.buf[old..]);
        let n = *read.as_ref().unwrap_or(&0);
        self.buf.truncate(old + n);
        self.eof = matches!(read, Ok(0));
        read.map(|_| ())
    }
}

impl<R: Read> Read for ChunkGuard<R> {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        loop {
            if let Some(why) = &self.refusal {
                return Err(io::Error::new(io::ErrorKind::InvalidData, why.clone()));
            }
            if self.checked > self.start {
                let n = out.len().min(self.checked - self.start);
                out[..n].copy_from_slice(&self.buf[self.start..self.start + n]);
                self.start += n;
                return Ok(n);
            }
            match self.step() {
                Ok(true) => continue,
                Ok(false) => {}
                Err(why) => {
                    self.refusal = Some(why);
                    continue;
                }
            }
            if self.eof {
                // A truncated header: hand on what is left; the reader reports the truncation.
                if self.start == self.buf.len() {
                    return Ok(0);
                }
                self.checked = self.buf.len();
                continue;
            }
            self.fill()?;
        }
    }
}

/// The little-endian u64 at `at` of a header slice known to hold it.
fn u64_at(header: &[u8], at: usize) -> u64 {
    let mut bytes = [0u8; 8];
    bytes.copy_from_slice(&header[at..at + 8]);
    u64::from_le_bytes(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// A bag of a few messages on two channels, written by the `mcap` crate's writer.
    fn written_bag(options: mcap::WriteOptions) -> Vec<u8> {
        let mut w = options.create(io::Cursor::new(Vec::new())).unwrap();
        let schema = w.add_schema("std_msgs/msg/Empty", "ros2msg", b"").unwrap();
        let a = w
            .add_channel(schema, "/a", "cdr", &BTreeMap::new())
            .unwrap();
        let b = w
            .add_channel(schema, "/b", "cdr", &BTreeMap::new())
            .unwrap();
        for k in 0..200u32 {
            let header = mcap::records::MessageHeader {
                channel_id: if k % 3 == 0 { a } else { b },
                sequence: k,
                log_time: u64::from(k),
                publish_time: u64::from(k),
            };
            w.write_to_known_channel(&header, &k.to_le_bytes().repeat(1 + k as usize % 7))
                .unwrap();
        }
        w.finish().unwrap();
        w.into_inner().into_inner()
    }

    /// Everything read through the guard in reads of `size` bytes.
    fn through_guard(bytes: &[u8], size: usize) -> io::Result<Vec<u8>> {
        let mut guard = ChunkGuard::new(bytes);
        let mut out = Vec::new();
        let mut part = vec![0; size];
        loop {
            match guard.read(&mut part)? {
                0 => return Ok(out),
                n => out.extend_from_slice(&part[..n]),
            }
        }
    }

    /// The guard hands on a well-formed file unchanged, whatever the read sizes and the
    /// chunking: uncompressed chunks (walked record by record), compressed ones (passed
    /// whole), no chunks.
    #[test]
    fn a_well_formed_file_passes_unchanged() {
        let plain = mcap::WriteOptions::new().compression(None);
        let bags = [
            (
                "plain chunks",
                written_bag(plain.clone().chunk_size(Some(300))),
            ),
            ("no chunks", written_bag(plain.use_chunks(false))),
            (
                "zstd chunks",
                written_bag(mcap::WriteOptions::new().chunk_size(Some(300))),
            ),
        ];
        for (what, bag) in &bags {
            for size in [1, 7, 9, 40, 4096, 1 << 20] {
                let read = through_guard(bag, size).unwrap();
                assert!(read == *bag, "{what} read {size} bytes at a time");
            }
        }
    }

    /// A file cut anywhere reads as far as it goes: the guard refuses nothing it cannot
    /// see, and leaves the truncation to the reader.
    #[test]
    fn a_truncated_file_passes_as_far_as_it_goes() {
        let bag = written_bag(
            mcap::WriteOptions::new()
                .compression(None)
                .chunk_size(Some(300)),
        );
        for cut in (0..bag.len()).step_by(13) {
            assert_eq!(
                through_guard(&bag[..cut], 5).unwrap(),
                &bag[..cut],
                "cut at {cut}"
            );
        }
    }

    /// The chunk of a well-formed bag with its first record lengthened by `more` bytes.
    fn overrun(more: u64) -> (Vec<u8>, usize) {
        let mut bag = written_bag(mcap::WriteOptions::new().compression(None));
        let mut chunk = MAGIC_BYTES as usize;
        while bag[chunk] != op::CHUNK {
            chunk += RECORD_HEADER_BYTES + u64_at(&bag[chunk..], 1) as usize;
        }
        let first = chunk + RECORD_HEADER_BYTES + CHUNK_HEADER_BYTES;
        let len = u64_at(&bag[first..], 1) + more;
        bag[first + 1..first + 9].copy_from_slice(&len.to_le_bytes());
        (bag, first)
    }

    #[test]
    fn a_record_overrunning_its_uncompressed_chunk_is_refused_with_its_offset() {
        let (bag, first) = overrun(1 << 20);
        let err = through_guard(&bag, 4096).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidData);
        let text = err.to_string();
        assert!(
            text.starts_with(&format!("the record at byte {first} declares ")),
            "{text}"
        );
        assert!(text.contains("but its uncompressed chunk holds"), "{text}");
        let mut guard = ChunkGuard::new(&bag[..]);
        let _ = io::copy(&mut guard, &mut io::sink());
        assert_eq!(guard.take_refusal(), Some(text));
        assert_eq!(guard.take_refusal(), None);
    }

    /// Framing that no reader could use: a chunk shorter than its header, records declared
    /// beyond the chunk, a chunk ending inside a record header.
    #[test]
    fn impossible_chunk_framing_is_refused() {
        let mut header = vec![0u8; CHUNK_HEADER_BYTES];
        let chunk = |body: &[u8], len: u64| {
            let mut bag = b"\x89MCAP0\r\n".to_vec();
            bag.push(op::CHUNK);
            bag.extend_from_slice(&len.to_le_bytes());
            bag.extend_from_slice(body);
            bag
        };
        let short = through_guard(&chunk(&header, 39), 64)
            .unwrap_err()
            .to_string();
        assert!(
            short.contains("the chunk at byte 8 holds 39 bytes, fewer than"),
            "{short}"
        );
        header[COMPRESSED_SIZE_AT..].copy_from_slice(&100u64.to_le_bytes());
        let beyond = through_guard(&chunk(&header, 99), 64)
            .unwrap_err()
            .to_string();
        assert!(
            beyond.contains("declares 100 bytes of records but holds 59"),
            "{beyond}"
        );
        header[COMPRESSED_SIZE_AT..].copy_from_slice(&4u64.to_le_bytes());
        let mut body = header.clone();
        body.extend_from_slice(&[0x05, 0, 0, 0]);
        let cut = through_guard(&chunk(&body, 44), 64)
            .unwrap_err()
            .to_string();
        assert!(
            cut.contains("ends 4 bytes into a record header at byte 57"),
            "{cut}"
        );
    }
}
