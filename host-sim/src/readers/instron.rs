//! Instron (Bluehill) compression test exported as CSV.
//!
//! Metadata lines (sample name, test type, specimen size, speed, machine, load cell), then
//! the header `Time (s),Compression (mm),Load (N),...`, then comma-separated rows. The
//! metadata lines are kept as notes.
//!
//! Conversions: compression is positive into the specimen (mm -> m); load is
//! compressive-positive \[N\], raw (the load cell offset is kept).

use std::io::BufRead;
use std::path::Path;

use super::error::{ReadError, ReadErrorKind};
use super::text::{
    check_row_length, decode_field, find_unit_column, parse_field, short, CsvLines, Samples,
    FORCE_UNITS, LENGTH_UNITS, TIME_UNITS,
};
use crate::record::{Format, Record};

const EXPECTED: [&str; 3] = ["Time (s)", "Compression (mm)", "Load (N)"];

/// `expected`: the expected number of samples, to size the columns (0: unknown).
pub(crate) fn read(input: impl BufRead, path: &Path, expected: usize) -> Result<Record, ReadError> {
    let io = |e| ReadError::file(path, ReadErrorKind::Io(e));
    let mut rows = CsvLines::new(input);
    // The header is the first line that starts with `Time (`; the lines before it are
    // metadata.
    let mut metadata: Vec<String> = Vec::new();
    let mut header = None;
    while rows.advance().map_err(io)? {
        if rows.field(0).starts_with(b"Time (") {
            header = Some((rows.line_number(), rows.strings()));
            break;
        }
        let note = decode_field(rows.raw());
        let note = note.trim().trim_end_matches([';', ',']).trim();
        if !note.is_empty() {
            metadata.push(note.to_owned());
        }
    }
    let missing = |line: Option<usize>, field: &str, found: Vec<String>| ReadError {
        path: path.to_path_buf(),
        line,
        field: Some(field.to_owned()),
        kind: ReadErrorKind::MissingColumn {
            expected: EXPECTED.iter().map(|s| (*s).to_owned()).collect(),
            found,
        },
    };
    let Some((header_line, header)) = header else {
        return Err(missing(None, "Time (s)", Vec::new()));
    };
    let column = |name: &str, units: &[(&str, f64)], expected: &str| {
        find_unit_column(&header, name, units)
            .ok_or_else(|| missing(Some(header_line), expected, header.clone()))
    };
    let (i_time, time_name, time_scale) = column("Time", TIME_UNITS, "Time (s)")?;
    let (i_comp, comp_name, comp_scale) = column("Compression", LENGTH_UNITS, "Compression (mm)")?;
    let (i_load, load_name, load_scale) = column("Load", FORCE_UNITS, "Load (N)")?;

    let mut samples = Samples::new(path, time_name, comp_name, load_name);
    samples.reserve(expected);
    while rows.advance().map_err(io)? {
        let line = rows.line_number();
        check_row_length(path, line, rows.len(), header.len(), header_line)?;
        let t = parse_field(path, line, time_name, rows.field(i_time))?;
        let compression = parse_field(path, line, comp_name, rows.field(i_comp))?;
        let load = parse_field(path, line, load_name, rows.field(i_load))?;
        samples.push(
            line,
            t * time_scale,
            compression * comp_scale,
            load * load_scale,
        )?;
    }

    let mut notes = vec![
        format!(
            "position into the material = `{comp_name}` x {} m (compression is positive into \
             the specimen)",
            short(comp_scale)
        ),
        format!(
            "force = `{load_name}` x {} N, compressive-positive, raw: the load offset is not \
             removed",
            short(load_scale)
        ),
        format!("time = `{time_name}` x {} s", short(time_scale)),
    ];
    notes.extend(metadata.into_iter().map(|m| format!("metadata: {m}")));
    samples.finish(Some(header_line), Format::Instron, Vec::new(), notes)
}
