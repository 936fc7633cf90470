//! Hysitron (TriboScan) nanoindentation text export.
//!
//! Line 1 a date, line 2 empty, line 3 `Number of Points = N`, line 4 a TAB header such
//! as `Depth (nm)<TAB>Load (µN)<TAB>Time (s)<TAB>Depth (V)<TAB>Load (V)`, then TAB rows.
//! Blank lines inside the data separate the sections of the load function; they become
//! segments `section 1`, `section 2`, ... (the file does not name them).
//!
//! The file is Latin-1 (the µ is the single byte 0xB5): it is decoded byte by byte,
//! never as UTF-8.
//!
//! Conversions: depth is already positive into the material (nm -> m); load is
//! compressive-positive (µN -> N), raw; the declared point count is checked.

use std::path::Path;

use super::error::{ReadError, ReadErrorKind};
use super::text::{
    cell, check_row_length, decode_latin1, find_unit_column, lines, parse_cell,
    segments_from_labels, short, Samples, FORCE_UNITS, LENGTH_UNITS, TIME_UNITS,
};
use crate::record::{Format, Record};

const POINTS: &str = "Number of Points";
const EXPECTED: [&str; 3] = ["Depth (nm)", "Load (µN)", "Time (s)"];

pub(crate) fn read(bytes: &[u8], path: &Path) -> Result<Record, ReadError> {
    let text = decode_latin1(bytes);
    let mut all = lines(&text);

    let mut preamble: Vec<String> = Vec::new();
    let mut declared: Option<(usize, usize)> = None;
    let mut header: Option<(usize, Vec<String>)> = None;
    for (line, raw) in all.by_ref() {
        let trimmed = raw.trim();
        if let Some(rest) = trimmed.strip_prefix(POINTS) {
            let value = rest.trim_start().strip_prefix('=').unwrap_or(rest).trim();
            let n = value.parse::<usize>().map_err(|_| {
                ReadError::at(
                    path,
                    line,
                    Some(POINTS),
                    ReadErrorKind::NonNumeric {
                        text: value.to_owned(),
                    },
                )
            })?;
            declared = Some((line, n));
        } else if raw.contains('\t') {
            header = Some((line, raw.split('\t').map(|c| c.trim().to_owned()).collect()));
            break;
        } else if !trimmed.is_empty() {
            preamble.push(trimmed.to_owned());
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
        return Err(missing(None, "Depth (nm)", Vec::new()));
    };
    let Some((points_line, declared)) = declared else {
        return Err(ReadError {
            path: path.to_path_buf(),
            line: Some(header_line),
            field: Some(POINTS.to_owned()),
            kind: ReadErrorKind::Invalid(format!("no `{POINTS} = N` line before the header")),
        });
    };
    let column = |name: &str, units: &[(&str, f64)], expected: &str| {
        find_unit_column(&header, name, units)
            .ok_or_else(|| missing(Some(header_line), expected, header.clone()))
    };
    let (i_depth, depth_name, depth_scale) = column("Depth", LENGTH_UNITS, "Depth (nm)")?;
    let (i_load, load_name, load_scale) = column("Load", FORCE_UNITS, "Load (µN)")?;
    let (i_time, time_name, time_scale) = column("Time", TIME_UNITS, "Time (s)")?;

    let mut samples = Samples::new(path, time_name, depth_name, load_name);
    let mut labels: Vec<Option<String>> = Vec::new();
    let mut section = 1usize;
    let mut section_open = false;
    let (mut first_line, mut last_line) = (None, None);
    for (line, raw) in all {
        if raw.trim().is_empty() {
            if section_open {
                section += 1;
                section_open = false;
            }
            continue;
        }
        let cells: Vec<&str> = raw.split('\t').collect();
        check_row_length(path, line, cells.len(), header.len(), header_line)?;
        let depth = parse_cell(path, line, depth_name, cell(&cells, i_depth))?;
        let load = parse_cell(path, line, load_name, cell(&cells, i_load))?;
        let t = parse_cell(path, line, time_name, cell(&cells, i_time))?;
        samples.push(line, t * time_scale, depth * depth_scale, load * load_scale)?;
        labels.push(Some(format!("section {section}")));
        section_open = true;
        first_line.get_or_insert(line);
        last_line = Some(line);
    }

    let found = samples.len();
    if found > 0 && found != declared {
        return Err(ReadError::at(
            path,
            points_line,
            Some(POINTS),
            ReadErrorKind::PointCount {
                declared,
                found,
                first_line,
                last_line,
            },
        ));
    }
    let segments = segments_from_labels(&labels);
    let mut notes = vec![
        format!(
            "position into the material = `{depth_name}` x {} m (depth is positive into the \
             material)",
            short(depth_scale)
        ),
        format!(
            "force = `{load_name}` x {} N, raw: the load offset is not removed",
            short(load_scale)
        ),
        format!("time = `{time_name}` x {} s", short(time_scale)),
        format!(
            "segments = the {} blank-line-separated sections of the data (unnamed in the file)",
            segments.len()
        ),
        "decoded as Latin-1 (byte 0xB5 = µ)".to_owned(),
    ];
    notes.extend(preamble.into_iter().map(|p| format!("header: {p}")));
    samples.finish(Some(header_line), Format::Hysitron, segments, notes)
}
