//! File readers: measured force/position files into a [`Record`] in SI, with position
//! positive into the material and force positive in compression, whatever the file's own
//! conventions. One module per format; [`read`] picks one by name or by content.
//!
//! No reader panics on any byte string: bad input is a [`ReadError`] that names the file,
//! the 1-based physical line and the field.

mod afm_tab;
mod error;
mod hysitron;
mod instron;
mod jpk;
mod project_csv;
mod text;

use std::path::Path;

pub use error::{ReadError, ReadErrorKind};

use crate::record::{Format, Record};

/// How many leading bytes auto-detection looks at.
const DETECT_PREFIX_BYTES: usize = 64 * 1024;

/// Reads `path` as `format`, or auto-detects the format from the content when `format`
/// is `None` (see [`detect`]).
///
/// # Errors
/// [`ReadError`]: I/O failure, empty file, undetectable format, or any content error of
/// the chosen reader (missing column, non-numeric or non-finite cell, time not strictly
/// increasing, fewer than 2 samples, ...).
pub fn read(path: &Path, format: Option<Format>) -> Result<Record, ReadError> {
    use std::io::{Read, Seek};
    let io = |e| ReadError::file(path, ReadErrorKind::Io(e));
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut prefix = Vec::with_capacity(DETECT_PREFIX_BYTES);
    (&mut file)
        .take(DETECT_PREFIX_BYTES as u64)
        .read_to_end(&mut prefix)
        .map_err(io)?;
    let format = resolve(&prefix, path, format)?;
    let length = file.metadata().map_or(0, |m| m.len());
    // Lines in the file, judged from the prefix: the columns are sized once instead of
    // doubling (three copies of a column at the last doubling).
    let lines = prefix.iter().filter(|&&b| b == b'\n').count().max(1);
    let rows = (length as f64 * lines as f64 / prefix.len().max(1) as f64 * 1.01) as usize;
    file.rewind().map_err(io)?;
    let stream = || std::io::BufReader::with_capacity(1 << 16, &file);
    match format {
        // The CSV formats are streamed (long logs); the others are small exports.
        Format::Csv => project_csv::read(stream(), path, rows),
        Format::Instron => instron::read(stream(), path, rows),
        _ => {
            let mut bytes = Vec::new();
            file.read_to_end(&mut bytes).map_err(io)?;
            read_bytes(&bytes, path, Some(format))
        }
    }
}

/// Like [`read`], on bytes already in memory; `source` names them in the record and in
/// errors.
///
/// # Errors
/// As [`read`], without the I/O failure.
pub fn read_bytes(
    bytes: &[u8],
    source: &Path,
    format: Option<Format>,
) -> Result<Record, ReadError> {
    match resolve(bytes, source, format)? {
        Format::Csv => project_csv::read(bytes, source, 0),
        Format::Jpk => jpk::read(bytes, source),
        Format::AfmTab => afm_tab::read(bytes, source),
        Format::Hysitron => hysitron::read(bytes, source),
        Format::Instron => instron::read(bytes, source, 0),
    }
}

/// The format to read `prefix` (the file's first bytes) as: `format` if given, else
/// [`detect`]ed; an all-whitespace prefix is an empty file.
fn resolve(prefix: &[u8], source: &Path, format: Option<Format>) -> Result<Format, ReadError> {
    if prefix.iter().all(u8::is_ascii_whitespace) {
        return Err(ReadError::file(source, ReadErrorKind::Empty));
    }
    match format {
        Some(f) => Ok(f),
        None => detect(prefix).ok_or_else(|| {
            ReadError::file(
                source,
                ReadErrorKind::UnknownFormat {
                    tried: Format::ALL.to_vec(),
                },
            )
        }),
    }
}

/// The format of `bytes` judged from their first lines, trying [`Format::ALL`] in order:
/// - jpk: first line `# TEXT EXPORT`;
/// - afm-tab: first line starts with `# afmformats`;
/// - hysitron: a line `Number of Points = ...` and a header containing `Depth (nm)`;
/// - instron: a header line starting `Time (s),` that contains `Load (N)`;
/// - csv: the first line that is not blank or a `#` comment has a `time_s` column.
pub fn detect(bytes: &[u8]) -> Option<Format> {
    // Latin-1 never fails and keeps every ASCII signature intact.
    let prefix = text::decode_latin1(bytes.get(..DETECT_PREFIX_BYTES).unwrap_or(bytes));
    let prefix = prefix.strip_prefix("\u{ef}\u{bb}\u{bf}").unwrap_or(&prefix);
    let head: Vec<&str> = text::lines(prefix).map(|(_, l)| l).take(100).collect();
    let first = head.first().map_or("", |l| l.trim());
    Format::ALL.into_iter().find(|f| match f {
        Format::Jpk => first == "# TEXT EXPORT",
        Format::AfmTab => first.starts_with("# afmformats"),
        Format::Hysitron => {
            let top = || head.iter().take(20);
            top().any(|l| l.trim_start().starts_with("Number of Points ="))
                && top().any(|l| l.contains("Depth (nm)"))
        }
        Format::Instron => head
            .iter()
            .any(|l| l.trim_start().starts_with("Time (s),") && l.contains("Load (N)")),
        Format::Csv => head
            .iter()
            .map(|l| l.trim())
            .find(|l| !l.is_empty() && !l.starts_with('#'))
            .is_some_and(|l| l.split(',').any(|c| c.trim().trim_matches('"') == "time_s")),
    })
}

/// What auto-detection looks for in each format, for error messages.
pub(crate) fn signature(format: Format) -> &'static str {
    match format {
        Format::Jpk => "first line `# TEXT EXPORT`",
        Format::AfmTab => "first line starting `# afmformats`",
        Format::Hysitron => "a line `Number of Points =` and a header with `Depth (nm)`",
        Format::Instron => "a header line starting `Time (s),` with `Load (N)`",
        Format::Csv => "a header with `time_s`",
    }
}
