//! The project's own log format: CSV with header `time_s,position_m,force_n` in SI, any
//! column order, extra columns ignored, `#` comment lines allowed. An optional `segment`
//! column (written by [`Record::write_csv`](crate::record::Record::write_csv)) gives each
//! sample's segment name; runs of equal names become segments.

use std::path::Path;

use super::error::ReadError;
use super::text::{
    cell, check_row_length, csv_records, decode_utf8_or_latin1, find_columns, lines, parse_cell,
    segments_from_labels, Samples,
};
use crate::record::{Format, Record};

const COLUMNS: [&str; 3] = ["time_s", "position_m", "force_n"];

pub(crate) fn read(bytes: &[u8], path: &Path) -> Result<Record, ReadError> {
    let text = decode_utf8_or_latin1(bytes);
    let records = csv_records(lines(&text));
    let mut records = records.into_iter();
    // Only comments and blank lines: report the missing header.
    let (header_line, header) = records.next().unwrap_or_default();
    let header_line = Some(header_line).filter(|&l| l > 0);
    let [it, ix, i_f] = find_columns(path, header_line, &header, &COLUMNS)?;
    let header_line = header_line.unwrap_or(0);
    let i_seg = header.iter().position(|h| h == "segment");

    let mut samples = Samples::new(path, "time_s", "position_m", "force_n");
    let mut labels: Vec<Option<String>> = Vec::new();
    for (line, cells) in records {
        check_row_length(path, line, cells.len(), header.len(), header_line)?;
        let t = parse_cell(path, line, "time_s", cell(&cells, it))?;
        let x = parse_cell(path, line, "position_m", cell(&cells, ix))?;
        let f = parse_cell(path, line, "force_n", cell(&cells, i_f))?;
        samples.push(line, t, x, f)?;
        labels.push(
            i_seg
                .map(|i| cell(&cells, i))
                .filter(|s| !s.is_empty())
                .map(str::to_owned),
        );
    }
    let segments = segments_from_labels(&labels);
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
