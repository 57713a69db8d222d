//! The length fields inside MCAP records, checked against the record that
//! holds them before the `mcap` crate reads it: the crate reserves a
//! string's or a byte array's claimed length before reading it, so one
//! corrupt `u32` asks for 4 GiB however short the file, which aborts the
//! process where memory is not overcommitted.
//!
//! The layouts are those of the MCAP specification (records `0x01`-`0x0F`);
//! the records of an uncompressed chunk are checked the same way. A
//! compressed chunk's records are left to the crate, whose decompression is
//! bounded by the record limit of [`super::mcap`].

/// The magic bytes that open an MCAP file.
const MAGIC: &[u8] = b"\x89MCAP0\r\n";

/// One field of a record.
#[derive(Clone, Copy)]
enum Field {
    /// A fixed number of bytes.
    Fixed(usize),
    /// A `u32` length and that many bytes (strings, schema data).
    Bytes32,
    /// A `u64` length and that many bytes (chunk records, attachments).
    Bytes64,
    /// A `u32` length and a map of strings to strings in that many bytes.
    StringMap,
    /// A `u32` length and that many bytes of fixed-size entries.
    Table,
    /// The rest of the record (a message's data).
    Rest,
}

use Field::*;

/// The fields of a record with `opcode`, in order; `None` for opcodes the
/// crate keeps as unknown bytes.
fn layout(opcode: u8) -> Option<&'static [Field]> {
    Some(match opcode {
        0x01 => &[Bytes32, Bytes32],
        0x02 => &[Fixed(20)],
        0x03 => &[Fixed(2), Bytes32, Bytes32, Bytes32],
        0x04 => &[Fixed(4), Bytes32, Bytes32, StringMap],
        0x05 => &[Fixed(22), Rest],
        0x06 => &[Fixed(28), Bytes32, Bytes64],
        0x07 => &[Fixed(2), Table],
        0x08 => &[Fixed(32), Table, Fixed(8), Bytes32, Fixed(16)],
        0x09 => &[Fixed(16), Bytes32, Bytes32, Bytes64, Fixed(4)],
        0x0A => &[Fixed(40), Bytes32, Bytes32],
        0x0B => &[Fixed(42), Table],
        0x0C => &[Bytes32, StringMap],
        0x0D => &[Fixed(16), Bytes32],
        0x0E => &[Fixed(17)],
        0x0F => &[Fixed(4)],
        _ => return None,
    })
}

/// `Err` naming the first record whose length fields claim more bytes than
/// it holds. Bytes that are not an MCAP file, or records cut short, pass:
/// the crate reports those itself without reading any field.
pub(super) fn check(bytes: &[u8]) -> Result<(), String> {
    match bytes.strip_prefix(MAGIC) {
        Some(records) => check_records(records, 0),
        None => Ok(()),
    }
}

/// Checks the records in `bytes`, `depth` chunks deep. A file cut short
/// is left to the crate, which reports it, except inside a chunk: the crate
/// streams a chunk's records and counts the chunk down by each record's
/// claimed length, so a record claiming more than its chunk holds
/// underflowed that count (a panic where overflow is checked; elsewhere
/// what follows is read as the chunk's records). A chunk's records must
/// fill it exactly, and a chunk the file cuts short is refused (the read
/// fails at the cut either way).
fn check_records(mut bytes: &[u8], depth: usize) -> Result<(), String> {
    let mut index = 0usize;
    let overrun = |index: usize, opcode: u8, claimed: u64, rest: usize| {
        format!(
            "record {index} (opcode {opcode:#04x}) of a chunk claims {claimed} bytes where {rest} remain in the chunk"
        )
    };
    while bytes.len() >= 9 {
        let opcode = bytes[0];
        let claimed = u64_at(bytes, 1);
        let content = usize::try_from(claimed)
            .ok()
            .and_then(|len| bytes.get(9..9usize.saturating_add(len)));
        let Some(content) = content else {
            if depth > 0 {
                return Err(overrun(index, opcode, claimed, bytes.len() - 9));
            }
            if opcode == 0x06 {
                return Err(format!(
                    "record {index} (opcode 0x06): a chunk of {claimed} bytes cut short after {}",
                    bytes.len() - 9
                ));
            }
            return Ok(());
        };
        let len = content.len();
        if let Some(fields) = layout(opcode) {
            check_fields(content, fields, opcode, depth)
                .map_err(|what| format!("record {index} (opcode {opcode:#04x}): {what}"))?;
        }
        bytes = &bytes[9 + len..];
        index += 1;
    }
    if depth > 0 && !bytes.is_empty() {
        return Err(format!(
            "a chunk ends in {} bytes, too few for a record",
            bytes.len()
        ));
    }
    Ok(())
}

/// Checks one record's `content` against its `fields`.
fn check_fields(content: &[u8], fields: &[Field], opcode: u8, depth: usize) -> Result<(), String> {
    let mut at = 0usize;
    let mut compression_none = false;
    for (k, field) in fields.iter().enumerate() {
        let rest = content.len() - at.min(content.len());
        let (header, claimed) = match *field {
            Fixed(n) => (0, n as u64),
            Bytes32 | StringMap | Table => (4, u32_at(content, at).map_or(u64::MAX, u64::from)),
            Bytes64 => (
                8,
                content.get(at..at + 8).map_or(u64::MAX, |b| u64_at(b, 0)),
            ),
            Rest => return Ok(()),
        };
        if (header as u64).saturating_add(claimed) > rest as u64 {
            return Err(format!(
                "field {k} claims {claimed} bytes where {} remain",
                rest.saturating_sub(header)
            ));
        }
        let body = &content[at + header..at + header + claimed as usize];
        match *field {
            StringMap => check_string_map(body)?,
            // A chunk's compression ("" for none) comes before its records.
            Bytes32 if opcode == 0x06 => compression_none = body.is_empty(),
            Bytes64 if opcode == 0x06 && compression_none && depth == 0 => {
                check_records(body, depth + 1)?
            }
            _ => {}
        }
        at += header + claimed as usize;
    }
    Ok(())
}

/// Checks that every string of a map's entries fits in the map.
fn check_string_map(mut body: &[u8]) -> Result<(), String> {
    while !body.is_empty() {
        for _ in 0..2 {
            let claimed = u32_at(body, 0).map_or(u64::MAX, u64::from);
            if claimed.saturating_add(4) > body.len() as u64 {
                return Err(format!(
                    "a map string claims {claimed} bytes where {} remain",
                    body.len().saturating_sub(4)
                ));
            }
            body = &body[4 + claimed as usize..];
        }
    }
    Ok(())
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

fn u64_at(bytes: &[u8], at: usize) -> u64 {
    let mut b = [0u8; 8];
    b.copy_from_slice(&bytes[at..at + 8]);
    u64::from_le_bytes(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record: opcode, little-endian length, content.
    fn record(opcode: u8, content: &[u8]) -> Vec<u8> {
        let mut r = vec![opcode];
        r.extend((content.len() as u64).to_le_bytes());
        r.extend(content);
        r
    }

    fn string(s: &[u8]) -> Vec<u8> {
        let mut r = (s.len() as u32).to_le_bytes().to_vec();
        r.extend(s);
        r
    }

    /// Regression (fuzzing `read_mcap`): a header whose library string
    /// claimed 4 GiB made the crate reserve 4 GiB for a record of a few
    /// bytes.
    #[test]
    fn a_string_longer_than_its_record_is_refused_before_reading() {
        let mut header = string(b"ros2");
        header.extend(u32::MAX.to_le_bytes());
        header.extend(b"x");
        let mut file = MAGIC.to_vec();
        file.extend(record(0x01, &header));
        let err = check(&file).unwrap_err();
        assert!(
            err.contains("record 0") && err.contains("4294967295"),
            "{err}"
        );
    }

    /// A well-formed header and channel pass; so do bytes that are no MCAP
    /// file or are cut short inside a record (the crate reports those).
    #[test]
    fn well_formed_records_and_short_files_pass() {
        let mut header = string(b"ros2");
        header.extend(string(b"turnprint"));
        let mut channel = vec![1, 0, 1, 0];
        channel.extend(string(b"/odom"));
        channel.extend(string(b"cdr"));
        let mut map = string(b"key");
        map.extend(string(b"value"));
        channel.extend(string(&map));
        let mut file = MAGIC.to_vec();
        file.extend(record(0x01, &header));
        file.extend(record(0x04, &channel));
        assert_eq!(check(&file), Ok(()));
        assert_eq!(check(&file[..file.len() - 3]), Ok(()));
        assert_eq!(check(b"not mcap"), Ok(()));
        // A map entry that claims more than the map holds.
        let mut bad = vec![1, 0, 1, 0];
        bad.extend(string(b"/odom"));
        bad.extend(string(b"cdr"));
        let mut map = string(b"key");
        map.extend(1000u32.to_le_bytes());
        bad.extend(string(&map));
        let mut file = MAGIC.to_vec();
        file.extend(record(0x04, &bad));
        assert!(check(&file).unwrap_err().contains("map string"));
    }

    /// Regression (`damaged_bags_never_panic`): a field whose length
    /// itself is cut off read as `u64::MAX`, and the check's sum wrapped.
    #[test]
    fn a_length_cut_off_by_the_record_end_is_refused() {
        let mut chunk = vec![0u8; 28];
        chunk.extend(string(b""));
        chunk.extend([1, 2, 3]);
        let mut file = MAGIC.to_vec();
        file.extend(record(0x06, &chunk));
        assert!(check(&file).is_err());
        let mut channel = vec![1, 0, 1, 0];
        channel.extend(string(b"/odom"));
        channel.extend(string(b"cdr"));
        channel.extend(string(&[3, 0, 0, 0, b'k', b'e', b'y', 9]));
        let mut file = MAGIC.to_vec();
        file.extend(record(0x04, &channel));
        assert!(check(&file).is_err());
    }

    /// Regression (fuzzing `read_auto`, 10 minutes): a record inside an
    /// uncompressed chunk claiming more bytes than the chunk holds (or a
    /// chunk ending in a partial record) underflowed the crate's count of
    /// the chunk's remaining bytes.
    #[test]
    fn a_record_longer_than_its_chunk_is_refused() {
        let inner = record(0x01, &[string(b"ros2"), string(b"")].concat());
        for records in [
            [&inner[..1], &100u64.to_le_bytes(), &inner[9..]].concat(),
            [&inner[..], &[0x01, 0, 0]].concat(),
        ] {
            let mut chunk = vec![0u8; 28];
            chunk.extend(string(b""));
            chunk.extend((records.len() as u64).to_le_bytes());
            chunk.extend(&records);
            let mut file = MAGIC.to_vec();
            file.extend(record(0x06, &chunk));
            let err = check(&file).unwrap_err();
            assert!(err.contains("chunk"), "{err}");
            // The file cut short inside the chunk: the crate would stream
            // the records that are there.
            let err = check(&file[..file.len() - 2]).unwrap_err();
            assert!(err.contains("cut short"), "{err}");
        }
    }

    /// Records inside an uncompressed chunk are checked too.
    #[test]
    fn a_bad_string_inside_an_uncompressed_chunk_is_refused() {
        let mut header = string(b"ros2");
        header.extend(u32::MAX.to_le_bytes());
        let inner = record(0x01, &header);
        let mut chunk = vec![0u8; 28];
        chunk.extend(string(b""));
        chunk.extend((inner.len() as u64).to_le_bytes());
        chunk.extend(&inner);
        let mut file = MAGIC.to_vec();
        file.extend(record(0x06, &chunk));
        assert!(check(&file).is_err());
    }
}
