//! Instron (Bluehill) compression test exported as CSV.
//!
//! Metadata lines (sample name, test type, specimen size, speed, machine, load cell), then
//! the header `Time (s),Compression (mm),Load (N),...`, then comma-separated rows. The
//! metadata lines are kept as notes.
//!
//! Conversions: compression is positive into the specimen (mm -> m); load is
//! compressive-positive \[N\], raw (the load cell offset is kept).

use std::path::Path;

use super::error::{ReadError, ReadErrorKind};
use super::text::{
    cell, check_row_length, csv_records, decode_utf8_or_latin1, find_unit_column, lines,
    parse_cell, short, Samples, FORCE_UNITS, LENGTH_UNITS, TIME_UNITS,
};
use crate::record::{Format, Record};

const EXPECTED: [&str; 3] = ["Time (s)", "Compression (mm)", "Load (N)"];

pub(crate) fn read(bytes: &[u8], path: &Path) -> Result<Record, ReadError> {
    let text = decode_utf8_or_latin1(bytes);
    // The header is the first line that starts with `Time (`; the lines before it are
    // metadata.
    let mut metadata: Vec<String> = Vec::new();
    let mut header_index = None;
    for (line, raw) in lines(&text) {
        if raw.trim_start().starts_with("Time (") {
            header_index = Some(line - 1);
            break;
        }
        let note = raw.trim().trim_end_matches([';', ',']).trim();
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
    let Some(lines_before) = header_index else {
        return Err(missing(None, "Time (s)", Vec::new()));
    };
    let mut records = csv_records(lines(&text).skip(lines_before)).into_iter();
    let Some((header_line, header)) = records.next() else {
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
    for (line, cells) in records {
        check_row_length(path, line, cells.len(), header.len(), header_line)?;
        let t = parse_cell(path, line, time_name, cell(&cells, i_time))?;
        let compression = parse_cell(path, line, comp_name, cell(&cells, i_comp))?;
        let load = parse_cell(path, line, load_name, cell(&cells, i_load))?;
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
