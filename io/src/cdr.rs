//! A small, bounds-checked reader of OMG CDR (XCDR1, the encoding ROS 2 writes into bags)
//! for the few message types `import-bag` needs: `sensor_msgs/msg/JointState`,
//! `geometry_msgs/msg/PoseStamped`, `PointStamped` and `TransformStamped`.
//!
//! Bags are untrusted bytes: every read checks the remaining length, sequence lengths are
//! bounded by the bytes left before anything is allocated, and a failure names the byte
//! offset and the field. Nothing here panics.

use std::fmt;

/// Why a message could not be decoded: the field and the byte offset (from the start of
/// the serialized message, encapsulation header included).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CdrError {
    pub offset: usize,
    pub what: String,
}

impl fmt::Display for CdrError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "byte {}: {}", self.offset, self.what)
    }
}

impl std::error::Error for CdrError {}

/// `builtin_interfaces/Time` as nanoseconds since the epoch (negative seconds allowed).
pub type StampNs = i128;

/// `std_msgs/Header`.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    pub stamp_ns: StampNs,
    pub frame_id: String,
}

/// `sensor_msgs/JointState` (velocity and effort are not needed and not kept).
#[derive(Debug, Clone, PartialEq)]
pub struct JointState {
    pub header: Header,
    pub name: Vec<String>,
    /// Joint positions [rad] or [m] for prismatic joints.
    pub position: Vec<f64>,
}

/// A measured pose: position [m] and unit quaternion (w, x, y, z) as sent.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseMsg {
    pub header: Header,
    /// `TransformStamped.child_frame_id` (empty for a PoseStamped).
    pub child_frame_id: String,
    pub position_m: [f64; 3],
    pub quaternion_wxyz: [f64; 4],
}

/// `geometry_msgs/PointStamped`: a measured point [m].
#[derive(Debug, Clone, PartialEq)]
pub struct PointMsg {
    pub header: Header,
    pub point_m: [f64; 3],
}

/// A cursor over one serialized message. Alignment is relative to the end of the
/// 4-byte encapsulation header, as CDR prescribes.
#[derive(Debug)]
pub struct CdrReader<'a> {
    buf: &'a [u8],
    pos: usize,
    little_endian: bool,
}

/// Length of the encapsulation header (representation id + options).
const ENCAPSULATION_LEN: usize = 4;

impl<'a> CdrReader<'a> {
    /// Reads the encapsulation header: plain CDR, little or big endian (ids 0x0000/0x0001;
    /// XCDR2's plain ids 0x0006/0x0007 are laid out alike for these final types).
    pub fn new(buf: &'a [u8]) -> Result<Self, CdrError> {
        let id = match buf.get(..ENCAPSULATION_LEN) {
            Some([a, b, _, _]) => [*a, *b],
            _ => {
                return Err(CdrError {
                    offset: 0,
                    what: format!(
                        "message of {} bytes has no 4-byte CDR encapsulation header",
                        buf.len()
                    ),
                });
            }
        };
        let little_endian = match id {
            [0x00, 0x01] => true,
            [0x00, 0x00] => false,
            other => {
                return Err(CdrError {
                    offset: 0,
                    what: format!(
                        "unsupported CDR representation 0x{:02x}{:02x} (expected plain CDR, 0x0000 or 0x0001)",
                        other[0], other[1]
                    ),
                });
            }
        };
        Ok(CdrReader {
            buf,
            pos: ENCAPSULATION_LEN,
            little_endian,
        })
    }

    fn err(&self, what: impl Into<String>) -> CdrError {
        CdrError {
            offset: self.pos,
            what: what.into(),
        }
    }

    fn remaining(&self) -> usize {
        self.buf.len().saturating_sub(self.pos)
    }

    fn align(&mut self, n: usize, field: &str) -> Result<(), CdrError> {
        let rel = self.pos - ENCAPSULATION_LEN;
        let pad = (n - rel % n) % n;
        if pad > self.remaining() {
            return Err(self.err(format!("message ends before {field}")));
        }
        self.pos += pad;
        Ok(())
    }

    fn take<const K: usize>(&mut self, field: &str) -> Result<[u8; K], CdrError> {
        self.align(K, field)?;
        let bytes: [u8; K] = self
            .buf
            .get(self.pos..self.pos + K)
            .and_then(|s| s.try_into().ok())
            .ok_or_else(|| self.err(format!("message ends inside {field}")))?;
        self.pos += K;
        Ok(bytes)
    }

    pub fn u32(&mut self, field: &str) -> Result<u32, CdrError> {
        let b = self.take::<4>(field)?;
        Ok(if self.little_endian {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    pub fn i32(&mut self, field: &str) -> Result<i32, CdrError> {
        let b = self.take::<4>(field)?;
        Ok(if self.little_endian {
            i32::from_le_bytes(b)
        } else {
            i32::from_be_bytes(b)
        })
    }

    pub fn f64(&mut self, field: &str) -> Result<f64, CdrError> {
        let b = self.take::<8>(field)?;
        Ok(if self.little_endian {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    /// A sequence length, refused when the elements (at least `min_elem_bytes` each) could
    /// not fit in what is left of the message: a hostile length allocates nothing.
    pub fn seq_len(&mut self, field: &str, min_elem_bytes: usize) -> Result<usize, CdrError> {
        let n = self.u32(field)? as usize;
        if n.saturating_mul(min_elem_bytes.max(1)) > self.remaining() {
            return Err(self.err(format!(
                "{field}: length {n} exceeds the {} bytes left",
                self.remaining()
            )));
        }
        Ok(n)
    }

    /// A CDR string: u32 length including the terminating NUL, then the bytes.
    pub fn string(&mut self, field: &str) -> Result<String, CdrError> {
        let n = self.seq_len(field, 1)?;
        let start = self.pos;
        let bytes = self
            .buf
            .get(start..start + n)
            .ok_or_else(|| self.err(format!("message ends inside {field}")))?;
        // ROS 2 writers always terminate; an empty string may be written with length 0.
        let text = match bytes.split_last() {
            Some((0, text)) => text,
            Some(_) => return Err(self.err(format!("{field}: string not NUL-terminated"))),
            None => &[],
        };
        let s = std::str::from_utf8(text)
            .map_err(|_| self.err(format!("{field}: string is not UTF-8")))?
            .to_string();
        self.pos = start + n;
        Ok(s)
    }

    fn f64_array<const K: usize>(&mut self, field: &str) -> Result<[f64; K], CdrError> {
        let mut out = [0.0; K];
        for v in &mut out {
            *v = self.f64(field)?;
        }
        Ok(out)
    }

    fn header(&mut self) -> Result<Header, CdrError> {
        let sec = self.i32("header.stamp.sec")?;
        let nanosec = self.u32("header.stamp.nanosec")?;
        let frame_id = self.string("header.frame_id")?;
        Ok(Header {
            stamp_ns: i128::from(sec) * 1_000_000_000 + i128::from(nanosec),
            frame_id,
        })
    }
}

/// Decodes a `sensor_msgs/msg/JointState`.
pub fn joint_state(buf: &[u8]) -> Result<JointState, CdrError> {
    let mut r = CdrReader::new(buf)?;
    let header = r.header()?;
    let n_names = r.seq_len("name", 4)?;
    let mut name = Vec::with_capacity(n_names);
    for _ in 0..n_names {
        name.push(r.string("name[]")?);
    }
    let n_pos = r.seq_len("position", 8)?;
    let mut position = Vec::with_capacity(n_pos);
    for _ in 0..n_pos {
        position.push(r.f64("position[]")?);
    }
    // velocity and effort follow; they are not used, but a message cut short is refused.
    for field in ["velocity", "effort"] {
        let n = r.seq_len(field, 8)?;
        for _ in 0..n {
            r.f64(field)?;
        }
    }
    Ok(JointState {
        header,
        name,
        position,
    })
}

/// Decodes a `geometry_msgs/msg/PoseStamped`.
pub fn pose_stamped(buf: &[u8]) -> Result<PoseMsg, CdrError> {
    let mut r = CdrReader::new(buf)?;
    let header = r.header()?;
    let position_m = r.f64_array::<3>("pose.position")?;
    let [x, y, z, w] = r.f64_array::<4>("pose.orientation")?;
    Ok(PoseMsg {
        header,
        child_frame_id: String::new(),
        position_m,
        quaternion_wxyz: [w, x, y, z],
    })
}

/// Decodes a `geometry_msgs/msg/TransformStamped` (the pose of `child_frame_id` in
/// `header.frame_id`).
pub fn transform_stamped(buf: &[u8]) -> Result<PoseMsg, CdrError> {
    let mut r = CdrReader::new(buf)?;
    let header = r.header()?;
    let child_frame_id = r.string("child_frame_id")?;
    let position_m = r.f64_array::<3>("transform.translation")?;
    let [x, y, z, w] = r.f64_array::<4>("transform.rotation")?;
    Ok(PoseMsg {
        header,
        child_frame_id,
        position_m,
        quaternion_wxyz: [w, x, y, z],
    })
}

/// Decodes a `geometry_msgs/msg/PointStamped`.
pub fn point_stamped(buf: &[u8]) -> Result<PointMsg, CdrError> {
    let mut r = CdrReader::new(buf)?;
    let header = r.header()?;
    let point_m = r.f64_array::<3>("point")?;
    Ok(PointMsg { header, point_m })
}

/// A CDR writer for the same messages: what the tests and the fuzz seeds use to make bags.
/// (The independent check is the Python `mcap`/CDR writer of `scripts/write_test_bag.py`.)
pub mod write {
    /// Little-endian plain CDR, alignment relative to the end of the 4-byte header.
    #[derive(Debug, Default)]
    pub struct CdrWriter {
        buf: Vec<u8>,
    }

    impl CdrWriter {
        pub fn new() -> Self {
            CdrWriter {
                buf: vec![0x00, 0x01, 0x00, 0x00],
            }
        }
        fn align(&mut self, n: usize) {
            while !(self.buf.len() - 4).is_multiple_of(n) {
                self.buf.push(0);
            }
        }
        pub fn u32(&mut self, v: u32) {
            self.align(4);
            self.buf.extend_from_slice(&v.to_le_bytes());
        }
        pub fn i32(&mut self, v: i32) {
            self.align(4);
            self.buf.extend_from_slice(&v.to_le_bytes());
        }
        pub fn f64(&mut self, v: f64) {
            self.align(8);
            self.buf.extend_from_slice(&v.to_le_bytes());
        }
        pub fn string(&mut self, s: &str) {
            self.u32(s.len() as u32 + 1);
            self.buf.extend_from_slice(s.as_bytes());
            self.buf.push(0);
        }
        pub fn header(&mut self, stamp_ns: i128, frame_id: &str) {
            self.i32(stamp_ns.div_euclid(1_000_000_000) as i32);
            self.u32(stamp_ns.rem_euclid(1_000_000_000) as u32);
            self.string(frame_id);
        }
        pub fn finish(self) -> Vec<u8> {
            self.buf
        }
    }

    /// A serialized `sensor_msgs/msg/JointState` (velocity and effort empty).
    pub fn joint_state(stamp_ns: i128, names: &[&str], position: &[f64]) -> Vec<u8> {
        let mut w = CdrWriter::new();
        w.header(stamp_ns, "");
        w.u32(names.len() as u32);
        for n in names {
            w.string(n);
        }
        w.u32(position.len() as u32);
        for p in position {
            w.f64(*p);
        }
        w.u32(0);
        w.u32(0);
        w.finish()
    }

    /// A serialized `geometry_msgs/msg/PoseStamped`; `q_wxyz` as (w, x, y, z).
    pub fn pose_stamped(stamp_ns: i128, frame: &str, p_m: [f64; 3], q_wxyz: [f64; 4]) -> Vec<u8> {
        let mut w = CdrWriter::new();
        w.header(stamp_ns, frame);
        for v in p_m {
            w.f64(v);
        }
        for v in [q_wxyz[1], q_wxyz[2], q_wxyz[3], q_wxyz[0]] {
            w.f64(v);
        }
        w.finish()
    }

    /// A serialized `geometry_msgs/msg/TransformStamped`.
    pub fn transform_stamped(
        stamp_ns: i128,
        frame: &str,
        child: &str,
        p_m: [f64; 3],
        q_wxyz: [f64; 4],
    ) -> Vec<u8> {
        let mut w = CdrWriter::new();
        w.header(stamp_ns, frame);
        w.string(child);
        for v in p_m {
            w.f64(v);
        }
        for v in [q_wxyz[1], q_wxyz[2], q_wxyz[3], q_wxyz[0]] {
            w.f64(v);
        }
        w.finish()
    }

    /// A serialized `geometry_msgs/msg/PointStamped`.
    pub fn point_stamped(stamp_ns: i128, frame: &str, p_m: [f64; 3]) -> Vec<u8> {
        let mut w = CdrWriter::new();
        w.header(stamp_ns, frame);
        for v in p_m {
            w.f64(v);
        }
        w.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joint_state_round_trips_with_alignment_padding() {
        // "a" makes the name sequence end off an 8-byte boundary: positions need padding.
        let bytes = write::joint_state(1_500_000_123, &["a", "joint_2"], &[0.25, -1.5]);
        let m = joint_state(&bytes).unwrap();
        assert_eq!(m.header.stamp_ns, 1_500_000_123);
        assert_eq!(m.name, ["a", "joint_2"]);
        assert_eq!(m.position, [0.25, -1.5]);
    }

    #[test]
    fn hand_laid_pose_stamped_little_endian() {
        // Independent of the writer: bytes laid out by hand from the CDR rules.
        let mut b = vec![0, 1, 0, 0];
        b.extend_from_slice(&7i32.to_le_bytes()); // sec
        b.extend_from_slice(&9u32.to_le_bytes()); // nanosec
        b.extend_from_slice(&2u32.to_le_bytes()); // "w\0"
        b.extend_from_slice(b"w\0");
        b.extend_from_slice(&[0, 0]); // pad 14 -> 16 (relative to byte 4)
        for v in [1.0f64, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        let m = pose_stamped(&b).unwrap();
        assert_eq!(m.header.stamp_ns, 7_000_000_009);
        assert_eq!(m.header.frame_id, "w");
        assert_eq!(m.position_m, [1.0, 2.0, 3.0]);
        assert_eq!(m.quaternion_wxyz, [1.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn big_endian_point_stamped() {
        let mut b = vec![0, 0, 0, 0];
        b.extend_from_slice(&1i32.to_be_bytes());
        b.extend_from_slice(&0u32.to_be_bytes());
        b.extend_from_slice(&1u32.to_be_bytes()); // "" with its NUL
        b.push(0);
        b.extend_from_slice(&[0, 0, 0]); // 13 -> 16
        for v in [0.5f64, -0.5, 2.0] {
            b.extend_from_slice(&v.to_be_bytes());
        }
        let m = point_stamped(&b).unwrap();
        assert_eq!(m.point_m, [0.5, -0.5, 2.0]);
        assert_eq!(m.header.stamp_ns, 1_000_000_000);
    }

    #[test]
    fn every_truncation_and_a_hostile_length_are_errors() {
        let bytes =
            write::transform_stamped(5, "world", "tool", [1.0, 2.0, 3.0], [1.0, 0.0, 0.0, 0.0]);
        assert!(transform_stamped(&bytes).is_ok());
        for n in 0..bytes.len() {
            assert!(
                transform_stamped(&bytes[..n]).is_err(),
                "prefix of {n} bytes"
            );
        }
        let mut hostile = write::joint_state(0, &[], &[]);
        hostile.truncate(4 + 8 + 4 + 1);
        hostile.extend_from_slice(&[0; 3]);
        hostile.extend_from_slice(&u32::MAX.to_le_bytes());
        let e = joint_state(&hostile).unwrap_err();
        assert!(e.what.contains("exceeds"), "{e}");
    }

    #[test]
    fn unknown_representation_is_named() {
        let e = point_stamped(&[0x00, 0x0a, 0, 0]).unwrap_err();
        assert!(e.what.contains("0x000a"), "{e}");
    }
}
