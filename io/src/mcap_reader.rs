//! The messages of an MCAP stream, read so that no length field of a damaged file decides
//! an allocation.
//!
//! The `mcap` crate's readers parse every record with binrw, which reserves a string's
//! u32-declared length before reading it: a damaged 60-byte bag could make them reserve
//! 4 GiB (found by the `ros_bag` fuzz target), and its chunk records had no length bound
//! at all. Here the crate's sans-io [`LinearReader`] frames the records (every record
//! bounded by [`MAX_RECORD_BYTES`]); only the three record kinds a bag import needs
//! (schema, channel, message) are parsed, after their length prefixes were checked against
//! the record's own size. The schema/channel bookkeeping is the crate's
//! [`ChannelAccumulator`], so the checks `MessageStream` applies still apply.
//!
//! The crate's reader trusts one more length: inside an uncompressed chunk it subtracts each
//! record's length from the chunk's remaining bytes without checking that the record fits
//! (`mcap` 0.26.0, found by the same fuzz target: a panic with overflow checks, a read past
//! the chunk in release). [`ChunkGuard`] walks the record framing of the bytes before the
//! reader sees them and refuses such a chunk with its byte offset.

use std::borrow::Cow;
use std::io::Read;

use mcap::read::ChannelAccumulator;
use mcap::records::{Record, op};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::{McapError, Message};

use self::guard::ChunkGuard;

mod guard;

/// The largest MCAP record (a message, or a chunk's compressed or uncompressed body) read:
/// 256 MiB. Bags for calibration hold joint states and poses (rosbag2 writes 768 KiB
/// chunks); a larger record is refused as damaged.
pub const MAX_RECORD_BYTES: usize = 256 << 20;

/// Bytes read from the source at a time. The reader asks for a whole record at once (up to
/// [`MAX_RECORD_BYTES`], zero-filled before it is read into): asking the source for at most
/// this much per read grows the reader's buffer with the bytes that really arrive, so a
/// damaged 100-byte file declaring a 200 MiB record costs 100 bytes, not 200 MiB.
const READ_BYTES: usize = 64 << 10;

/// Why a stream could not be read: the crate's error, or a record's own framing (a length
/// prefix larger than its record, a message after the data section).
#[derive(Debug)]
pub enum ReadError {
    Mcap(McapError),
    Framing(String),
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Mcap(e) => write!(f, "{e}"),
            Self::Framing(s) => f.write_str(s),
        }
    }
}

impl From<McapError> for ReadError {
    fn from(e: McapError) -> Self {
        Self::Mcap(e)
    }
}

impl From<std::io::Error> for ReadError {
    fn from(e: std::io::Error) -> Self {
        Self::Mcap(e.into())
    }
}

/// The messages of one MCAP stream in file order; nothing after the first error.
pub struct Messages<R> {
    source: ChunkGuard<R>,
    reader: LinearReader,
    channels: ChannelAccumulator<'static>,
    past_data_end: bool,
    done: bool,
}

impl<R: Read> Messages<R> {
    pub fn new(source: R) -> Self {
        let options = LinearReaderOptions::default()
            .with_record_length_limit(MAX_RECORD_BYTES)
            .with_emit_chunks(false);
        Self {
            source: ChunkGuard::new(source),
            reader: LinearReader::new_with_options(options),
            channels: ChannelAccumulator::default(),
            past_data_end: false,
            done: false,
        }
    }

    fn next_message(&mut self) -> Option<Result<Message<'static>, ReadError>> {
        loop {
            let event = match self.reader.next_event()? {
                Ok(event) => event,
                Err(e) => return Some(Err(e.into())),
            };
            let (opcode, data) = match event {
                LinearReadEvent::ReadRequest(need) => {
                    if let Err(e) = self.fill(need) {
                        return Some(Err(e));
                    }
                    continue;
                }
                LinearReadEvent::Record { opcode, data } => (opcode, data),
            };
            // Records after the data section (the summary) repeat schemas and channels: read
            // to the end magic without parsing them, like the crate's MessageStream. The
            // summary holds no messages: one there (or a data end inside a chunk, which
            // the spec forbids) is damage, refused rather than dropped unseen.
            if opcode == op::DATA_END {
                self.past_data_end = true;
                continue;
            }
            if self.past_data_end {
                if opcode == op::MESSAGE {
                    return Some(Err(ReadError::Framing(
                        "a message after the data end record".into(),
                    )));
                }
                continue;
            }
            if !matches!(opcode, op::SCHEMA | op::CHANNEL | op::MESSAGE) {
                continue;
            }
            if let Err(e) = check_prefixes(opcode, data) {
                return Some(Err(e));
            }
            match link(&mut self.channels, opcode, data) {
                Ok(Some(message)) => return Some(Ok(message)),
                Ok(None) => {}
                Err(e) => return Some(Err(e)),
            }
        }
    }

    /// Reads up to `need` bytes, at most [`READ_BYTES`], into the reader (0 at the end of
    /// the stream).
    fn fill(&mut self, need: usize) -> Result<(), ReadError> {
        let read = loop {
            match self.source.read(self.reader.insert(need.min(READ_BYTES))) {
                Ok(n) => break n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    return Err(match self.source.take_refusal() {
                        Some(why) => ReadError::Framing(why),
                        None => e.into(),
                    });
                }
            }
        };
        self.reader.notify_read(read);
        Ok(())
    }
}

impl<R> std::fmt::Debug for Messages<R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Messages")
            .field("past_data_end", &self.past_data_end)
            .field("done", &self.done)
            .finish_non_exhaustive()
    }
}

impl<R: Read> Iterator for Messages<R> {
    type Item = Result<Message<'static>, ReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let next = self.next_message();
        self.done = !matches!(next, Some(Ok(_)));
        next
    }
}

/// Parses a schema, channel or message record (prefixes already checked) and links it:
/// schemas and channels are recorded, a message is returned with its channel.
fn link(
    channels: &mut ChannelAccumulator<'static>,
    opcode: u8,
    data: &[u8],
) -> Result<Option<Message<'static>>, ReadError> {
    match mcap::parse_record(opcode, data)? {
        Record::Schema { header, data } => {
            channels.add_schema(header, Cow::Owned(data.into_owned()))?;
            Ok(None)
        }
        Record::Channel(channel) => {
            channels.add_channel(channel)?;
            Ok(None)
        }
        Record::Message { header, data } => {
            let channel = channels
                .get(header.channel_id)
                .ok_or(McapError::UnknownChannel(
                    header.sequence,
                    header.channel_id,
                ))?;
            Ok(Some(Message {
                channel,
                sequence: header.sequence,
                log_time: header.log_time,
                publish_time: header.publish_time,
                data: Cow::Owned(data.into_owned()),
            }))
        }
        _ => Ok(None),
    }
}

/// Checks every u32 length prefix of a schema or channel record against the bytes left in
/// the record, before binrw reserves what they declare. (A message has no prefix: its data
/// is the rest of the record.)
fn check_prefixes(opcode: u8, record: &[u8]) -> Result<(), ReadError> {
    let mut at = Prefixes { record, at: 0 };
    match opcode {
        op::SCHEMA => {
            at.skip(2)?; // id
            at.string("schema name")?;
            at.string("schema encoding")?;
            at.string("schema data")?;
        }
        op::CHANNEL => {
            at.skip(4)?; // id, schema id
            at.string("channel topic")?;
            at.string("channel message encoding")?;
            let map_len = at.u32("channel metadata")?;
            let start = at.at;
            while at.at - start < map_len {
                at.string("channel metadata key")?;
                at.string("channel metadata value")?;
            }
        }
        _ => {}
    }
    Ok(())
}

/// A cursor over one record's bytes for [`check_prefixes`].
struct Prefixes<'a> {
    record: &'a [u8],
    at: usize,
}

impl Prefixes<'_> {
    fn left(&self) -> usize {
        self.record.len().saturating_sub(self.at)
    }

    fn too_long(&self, what: &str, declared: usize) -> ReadError {
        ReadError::Framing(format!(
            "{what} declares {declared} bytes but its record holds {} more",
            self.left()
        ))
    }

    fn skip(&mut self, n: usize) -> Result<(), ReadError> {
        if n > self.left() {
            return Err(self.too_long("a record header", n));
        }
        self.at += n;
        Ok(())
    }

    fn u32(&mut self, what: &str) -> Result<usize, ReadError> {
        let bytes = self
            .record
            .get(self.at..self.at + 4)
            .ok_or_else(|| self.too_long(what, 4))?;
        self.at += 4;
        let n = u32::from_le_bytes(bytes.try_into().unwrap_or([0xff; 4])) as usize;
        if n > self.left() {
            return Err(self.too_long(what, n));
        }
        Ok(n)
    }

    /// A u32-prefixed string or byte array.
    fn string(&mut self, what: &str) -> Result<(), ReadError> {
        let n = self.u32(what)?;
        self.at += n;
        Ok(())
    }
}
