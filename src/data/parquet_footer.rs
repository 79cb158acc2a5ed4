//! The footer of a Parquet file checked before polars reads it.
//!
//! polars' Parquet reader trusts the numbers of a file's footer: a negative or overflowing
//! byte offset panics inside it, and a count of values far beyond what the file can hold makes
//! it reserve memory for that many. A damaged or hostile file (a data file a user imports, a
//! chain part) must be refused with an error instead, so every reader of Parquet in slipbayes
//! passes the footer through [`check_footer`] first.

use std::io::{Read, Seek, SeekFrom};

use polars_parquet_format::thrift::protocol::TCompactInputProtocol;
use polars_parquet_format::FileMetaData;

/// Values a column chunk may claim per byte of the file. Real files stay far below it (a run
/// of one repeated value, RLE-encoded, is the densest a writer makes); a claim beyond it would
/// only make the decoder reserve memory the file cannot fill.
const MAX_VALUES_PER_BYTE: u64 = 4096;

/// Why a Parquet footer could not be read ([`read_footer`]).
pub(crate) enum FooterError {
    /// The file could not be read.
    Io(std::io::Error),
    /// It holds no footer, or one that does not decode: what is wrong, as a phrase.
    Invalid(String),
}

/// The footer of the Parquet file `file`, decoded: where its metadata starts, the metadata,
/// and the file's size. Shared by the check below and by the chain store's footer rewrite.
pub(crate) fn read_footer(
    file: &mut (impl Read + Seek),
) -> Result<(u64, FileMetaData, u64), FooterError> {
    let size = file.seek(SeekFrom::End(0)).map_err(FooterError::Io)?;
    let no_footer = || FooterError::Invalid("no Parquet footer at the end".to_owned());
    if size < 12 {
        return Err(no_footer());
    }
    let mut tail = [0u8; 8];
    file.seek(SeekFrom::End(-8))
        .and_then(|_| file.read_exact(&mut tail))
        .map_err(FooterError::Io)?;
    if &tail[4..] != b"PAR1" {
        return Err(no_footer());
    }
    let length = u64::from(u32::from_le_bytes([tail[0], tail[1], tail[2], tail[3]]));
    let start = size
        .checked_sub(8 + length)
        .filter(|&s| s >= 4)
        .ok_or_else(no_footer)?;
    let mut bytes = vec![0u8; length as usize];
    file.seek(SeekFrom::Start(start))
        .and_then(|_| file.read_exact(&mut bytes))
        .map_err(FooterError::Io)?;
    // The bound the Parquet reader itself uses against a hostile footer.
    let max_size = bytes.len() * 2 + 1024;
    let metadata =
        FileMetaData::read_from_in_protocol(&mut TCompactInputProtocol::new(&bytes[..], max_size))
            .map_err(|e| FooterError::Invalid(format!("its footer is unreadable: {e}")))?;
    Ok((start, metadata, size))
}

/// Reads the footer of the Parquet file `file` and checks every count and byte range in it
/// against the file's size. Returns what is wrong, as a phrase, when a reader must not go on.
pub(crate) fn check_footer(file: &mut (impl Read + Seek)) -> Result<(), String> {
    let (_, metadata, size) = read_footer(file).map_err(|e| match e {
        FooterError::Io(e) => format!("cannot read it: {e}"),
        FooterError::Invalid(problem) => problem,
    })?;
    let max_values = size.saturating_mul(MAX_VALUES_PER_BYTE);
    let count = |what: &str, n: i64| -> Result<u64, String> {
        u64::try_from(n)
            .ok()
            .filter(|&n| n <= max_values)
            .ok_or_else(|| format!("its footer claims {n} {what} in a file of {size} bytes"))
    };
    count("rows", metadata.num_rows)?;
    // polars decodes the Arrow schema it finds under this key and indexes its first 4 (and,
    // after a continuation marker, 8) bytes unchecked; any real schema is far longer than 16
    // base64 characters (12 bytes).
    let arrow_schema = metadata
        .key_value_metadata
        .iter()
        .flatten()
        .find(|kv| kv.key == "ARROW:schema");
    if let Some(value) = arrow_schema.and_then(|kv| kv.value.as_deref()) {
        if value.len() < 16 {
            return Err(format!(
                "its footer's Arrow schema is {} characters long, too short to be one",
                value.len()
            ));
        }
    }
    for (g, group) in metadata.row_groups.iter().enumerate() {
        count(&format!("rows in row group {g}"), group.num_rows)?;
        for (c, chunk) in group.columns.iter().enumerate() {
            let Some(m) = &chunk.meta_data else {
                return Err(format!("column {c} of row group {g} has no metadata"));
            };
            count(
                &format!("values in column {c} of row group {g}"),
                m.num_values,
            )?;
            let place = |offset: i64, len: i64| -> Option<()> {
                let offset = u64::try_from(offset).ok()?;
                let end = offset.checked_add(u64::try_from(len).ok()?)?;
                (end <= size).then_some(())
            };
            let first = m.dictionary_page_offset.unwrap_or(m.data_page_offset);
            place(first, m.total_compressed_size)
                .and_then(|()| place(m.data_page_offset, 0))
                .and_then(|()| u64::try_from(m.total_uncompressed_size).ok().map(drop))
                .ok_or_else(|| {
                    format!(
                        "column {c} of row group {g} lies at bytes {first}..+{} of a file of \
                         {size} bytes",
                        m.total_compressed_size
                    )
                })?;
        }
    }
    Ok(())
}
