//! The project's own log format: CSV with header `time_s,position_m,force_n` in SI, any
//! column order, extra columns ignored, `#` comment lines allowed. An optional `segment`
//! column (written by [`Record::write_csv`](crate::record::Record::write_csv)) gives each
//! sample's segment name; runs of equal names become segments.
//!
//! Streamed: one reused line buffer, no per-row allocation (a 600 s, 1 kHz log is read in
//! the memory of its three columns).

use std::io::BufRead;
use std::path::Path;

use super::error::{ReadError, ReadErrorKind};
use super::text::{check_row_length, find_columns, parse_field, CsvLines, Samples, SegmentRuns};
use crate::record::{Format, Record};

const COLUMNS: [&str; 3] = ["time_s", "position_m", "force_n"];

/// `expected`: the expected number of samples, to size the columns (0: unknown).
pub(crate) fn read(input: impl BufRead, path: &Path, expected: usize) -> Result<Record, ReadError> {
    let io = |e| ReadError::file(path, ReadErrorKind::Io(e));
    let mut rows = CsvLines::new(input);
    // Only comments and blank lines: report the missing header.
    let (header_line, header) = if rows.advance().map_err(io)? {
        (Some(rows.line_number()), rows.strings())
    } else {
        (None, Vec::new())
    };
    let [it, ix, i_f] = find_columns(path, header_line, &header, &COLUMNS)?;
    let header_line = header_line.unwrap_or(0);
    let i_seg = header.iter().position(|h| h == "segment");

    let mut samples = Samples::new(path, "time_s", "position_m", "force_n");
    samples.reserve(expected);
    let mut segments = SegmentRuns::default();
    while rows.advance().map_err(io)? {
        let line = rows.line_number();
        check_row_length(path, line, rows.len(), header.len(), header_line)?;
        let t = parse_field(path, line, "time_s", rows.field(it))?;
        let x = parse_field(path, line, "position_m", rows.field(ix))?;
        let f = parse_field(path, line, "force_n", rows.field(i_f))?;
        samples.push(line, t, x, f)?;
        if let Some(i) = i_seg {
            segments.push(rows.field(i));
        }
    }
    let segments = segments.finish();
    let mut notes = vec![
        "project format: time_s [s], position_m [m] into the material, force_n [N] \
         compressive-positive; read as is, no conversion"
            .to_owned(),
    ];
    if i_seg.is_some() {
        notes.push(format!(
            "{} segment(s) from the `segment` column",
            segments.len()
        ));
    }
    samples.finish(Some(header_line), Format::Csv, segments, notes)
}
