//! TFRecord framing: the container WOMD ships its `Scenario` protobufs in.
//!
//! This module owns splitting a TFRecord file into its records and checking
//! both CRCs of each; it knows nothing about what the payloads mean. A record
//! is `u64` little-endian payload length, `u32` masked CRC-32C of those 8
//! length bytes, the payload, `u32` masked CRC-32C of the payload. Broken
//! framing is reported with the record index and the byte offset where that
//! record starts, and a bogus length is checked against the bytes that are
//! left before anything is sliced, so garbage input can neither panic nor
//! make the reader allocate.

use std::path::Path;

use super::{ImportError, Location};
use crate::scenario::SourceFormat;

/// Bytes of the length field.
const LENGTH_BYTES: usize = 8;
/// Bytes of each CRC field.
const CRC_BYTES: usize = 4;
/// Bytes of framing around every payload.
const FRAMING_BYTES: usize = LENGTH_BYTES + 2 * CRC_BYTES;

/// One record of a TFRecord file, borrowed from the file's bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Record<'a> {
    /// Zero-based position of the record in the file.
    pub index: usize,
    /// Offset of the record's length field from the start of the file.
    pub byte_offset: u64,
    /// The payload (for WOMD: one serialised `Scenario`).
    pub payload: &'a [u8],
}

impl Record<'_> {
    /// Where this record is, for error messages.
    pub fn location(&self) -> Location {
        Location::Record { index: self.index, byte_offset: self.byte_offset }
    }
}

/// The masked CRC-32C TensorFlow stores: masking keeps a CRC of data that
/// itself contains CRCs from looking like a valid CRC of it.
pub fn masked_crc32c(bytes: &[u8]) -> u32 {
    let crc = crc32c::crc32c(bytes);
    crc.rotate_right(15).wrapping_add(0xa282_ead8)
}

/// Reads a little-endian `u32` at `at`; `None` when the bytes run out.
fn read_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let end = at.checked_add(CRC_BYTES)?;
    let b: [u8; CRC_BYTES] = bytes.get(at..end)?.try_into().ok()?;
    Some(u32::from_le_bytes(b))
}

/// Splits `bytes` into records, checking both CRCs of each. An empty file
/// has no records. Any framing problem is an [`ImportError::Malformed`]
/// at [`Location::Record`] (index and start of the record), whose message
/// names the byte offset of the field that is wrong.
pub fn read_records<'a>(bytes: &'a [u8], path: &Path) -> Result<Vec<Record<'a>>, ImportError> {
    let mut records = Vec::new();
    let mut at = 0usize;
    while at < bytes.len() {
        let index = records.len();
        let start = at as u64;
        let fail = |offset: usize, what: String| {
            ImportError::malformed(
                path,
                SourceFormat::WomdProto,
                Location::Record { index, byte_offset: start },
                format!("TFRecord framing, field at byte {offset}: {what}"),
            )
        };
        let remaining = bytes.len() - at;
        if remaining < FRAMING_BYTES {
            return Err(fail(
                at,
                format!("truncated: {remaining} bytes left, a record needs at least {FRAMING_BYTES} bytes of framing"),
            ));
        }
        let length_bytes = bytes.get(at..at + LENGTH_BYTES).ok_or_else(|| fail(at, "truncated length".into()))?;
        let mut length_le = [0u8; LENGTH_BYTES];
        length_le.copy_from_slice(length_bytes);
        let length = u64::from_le_bytes(length_le);
        let length_crc = read_u32(bytes, at + LENGTH_BYTES).ok_or_else(|| fail(at, "truncated length CRC".into()))?;
        // The length CRC is checked before the length is trusted, so a
        // corrupted length reads as corruption rather than as truncation.
        let expected = masked_crc32c(length_bytes);
        if length_crc != expected {
            return Err(fail(
                at + LENGTH_BYTES,
                format!(
                    "length CRC mismatch (stored {length_crc:#010x}, computed {expected:#010x}): not a TFRecord file or corrupted"
                ),
            ));
        }
        let payload_start = at + LENGTH_BYTES + CRC_BYTES;
        let available = (bytes.len() - payload_start).saturating_sub(CRC_BYTES);
        let payload_len = match usize::try_from(length) {
            Ok(n) if n <= available => n,
            _ => {
                return Err(fail(
                    payload_start,
                    format!("truncated: record claims {length} payload bytes but only {available} remain"),
                ));
            }
        };
        let payload_end = payload_start + payload_len;
        let payload =
            bytes.get(payload_start..payload_end).ok_or_else(|| fail(payload_start, "truncated payload".into()))?;
        let payload_crc =
            read_u32(bytes, payload_end).ok_or_else(|| fail(payload_end, "truncated payload CRC".into()))?;
        let expected = masked_crc32c(payload);
        if payload_crc != expected {
            return Err(fail(
                payload_end,
                format!(
                    "payload CRC mismatch (stored {payload_crc:#010x}, computed {expected:#010x}): corrupted record"
                ),
            ));
        }
        records.push(Record { index, byte_offset: start, payload });
        at = payload_end + CRC_BYTES;
    }
    Ok(records)
}

/// Frames `payload` as one TFRecord record (for tests and tools that write
/// small files).
pub fn frame_record(payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(payload.len() + FRAMING_BYTES);
    let length = (payload.len() as u64).to_le_bytes();
    out.extend_from_slice(&length);
    out.extend_from_slice(&masked_crc32c(&length).to_le_bytes());
    out.extend_from_slice(payload);
    out.extend_from_slice(&masked_crc32c(payload).to_le_bytes());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path() -> &'static Path {
        Path::new("test.tfrecord")
    }

    fn message(e: ImportError) -> String {
        e.to_string()
    }

    #[test]
    fn known_masked_crc() {
        // CRC-32C check value of "123456789" is 0xe3069283; masked by hand
        // with TensorFlow's formula (computed independently in Python).
        assert_eq!(crc32c::crc32c(b"123456789"), 0xe306_9283);
        assert_eq!(masked_crc32c(b"123456789"), 0xc78a_b0e5);
        assert_eq!(masked_crc32c(&[0u8; 8]), 0x0798_0329);
    }

    #[test]
    fn round_trip_of_several_records() {
        let mut file = frame_record(b"first");
        file.extend(frame_record(b""));
        file.extend(frame_record(&[7u8; 300]));
        let records = read_records(&file, path()).unwrap();
        assert_eq!(records.len(), 3);
        assert_eq!(records[0].payload, b"first");
        assert_eq!(records[1].payload, b"");
        assert_eq!(records[1].byte_offset, (16 + 5) as u64);
        assert_eq!(records[2].index, 2);
        assert_eq!(records[2].byte_offset, (16 + 5 + 16) as u64);
        assert_eq!(records[2].payload.len(), 300);
    }

    #[test]
    fn empty_file_has_no_records() {
        assert!(read_records(&[], path()).unwrap().is_empty());
    }

    #[test]
    fn truncation_anywhere_is_an_error_naming_the_record() {
        let mut file = frame_record(b"first record");
        let second = file.len();
        file.extend(frame_record(b"second record"));
        for cut in 1..file.len() {
            if cut == second {
                continue;
            }
            let e = read_records(&file[..cut], path()).unwrap_err();
            let want = if cut < second { "record 0" } else { "record 1" };
            assert!(message(e).contains(want), "cut at {cut}");
        }
    }

    #[test]
    fn flipped_bytes_are_crc_errors() {
        let file = frame_record(b"payload bytes");
        for i in 0..file.len() {
            let mut bad = file.clone();
            bad[i] ^= 0x10;
            let e = message(read_records(&bad, path()).unwrap_err());
            assert!(e.contains("record 0"), "{e}");
            assert!(e.contains("CRC") || e.contains("truncated"), "{e}");
        }
    }

    #[test]
    fn huge_length_is_refused_without_allocating() {
        let length = u64::MAX.to_le_bytes();
        let mut file = length.to_vec();
        file.extend_from_slice(&masked_crc32c(&length).to_le_bytes());
        file.extend_from_slice(&[0u8; 8]);
        let e = message(read_records(&file, path()).unwrap_err());
        assert!(e.contains("claims") && e.contains("byte 12"), "{e}");
    }

    #[test]
    fn garbage_is_an_error() {
        let e = message(read_records(b"{\"not\": \"a tfrecord\"}", path()).unwrap_err());
        assert!(e.contains("test.tfrecord") && e.contains("length CRC"), "{e}");
    }
}
