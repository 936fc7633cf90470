//! afmformats tab-separated export (`afmformats.export_data(..., fmt="tab")`).
//!
//! `#` lines: `# afmformats <version>`, then JSON metadata between `# BEGIN METADATA` and
//! `# END METADATA` (each line prefixed `# `), and LAST the column header, e.g.
//! `# force<TAB>height (measured)<TAB>height (piezo)<TAB>segment<TAB>time` (SI: N, m, m,
//! index, s). Then TAB-separated rows. Sampling may differ by segment.
//!
//! Conversions:
//! - force = `force` \[N\], raw;
//! - position into the material x = −(height (measured) + force / k), k = metadata
//!   `"spring constant"`, the same model as the JPK reader (see `read`);
//! - segments from the `segment` column, named from the metadata `"imaging mode"`.

use std::path::Path;

use super::error::{ReadError, ReadErrorKind};
use super::text::{
    cell, check_row_length, decode_utf8_or_latin1, find_columns, lines, parse_cell,
    segments_from_labels, short, Samples,
};
use crate::record::{Format, Record};

const FORCE: &str = "force";
const HEIGHT: &str = "height (measured)";
const TIME: &str = "time";
const SEGMENT: &str = "segment";
const SPRING_CONSTANT: &str = "spring constant";

pub(crate) fn read(bytes: &[u8], path: &Path) -> Result<Record, ReadError> {
    let text = decode_utf8_or_latin1(bytes);
    let mut comments: Vec<(usize, &str)> = Vec::new();
    let mut rows: Vec<(usize, &str)> = Vec::new();
    for (line, raw) in lines(&text) {
        if raw.trim().is_empty() {
            continue;
        }
        match raw.trim_start().strip_prefix('#') {
            // `#` lines after the first data row are ignored, as comments.
            Some(comment) if rows.is_empty() => {
                comments.push((line, comment.strip_prefix(' ').unwrap_or(comment)));
            }
            Some(_) => {}
            None => rows.push((line, raw)),
        }
    }

    let metadata = parse_metadata(path, &comments)?;
    let (k, k_line) = spring_constant(path, &metadata, &comments)?;
    let Some(&(header_line, header_text)) = comments.last() else {
        return Err(ReadError::file(
            path,
            ReadErrorKind::Invalid("no `#` header lines (metadata and column header)".into()),
        ));
    };
    let header: Vec<String> = header_text
        .split('\t')
        .map(|c| c.trim().to_owned())
        .collect();
    let [i_f, ih, it] = find_columns(path, Some(header_line), &header, &[FORCE, HEIGHT, TIME])?;
    let i_seg = header.iter().position(|h| h == SEGMENT);

    let mut samples = Samples::new(path, TIME, HEIGHT, FORCE);
    let mut segment_ids: Vec<Option<u32>> = Vec::with_capacity(rows.len());
    for (line, raw) in rows {
        let cells: Vec<&str> = raw.split('\t').collect();
        check_row_length(path, line, cells.len(), header.len(), header_line)?;
        let force = parse_cell(path, line, FORCE, cell(&cells, i_f))?;
        let height = parse_cell(path, line, HEIGHT, cell(&cells, ih))?;
        let t = parse_cell(path, line, TIME, cell(&cells, it))?;
        let segment = match i_seg {
            Some(i) => Some(segment_index(path, line, cell(&cells, i))?),
            None => None,
        };
        // The README says "tip position = height − F/k"; the data says otherwise.
        // `height (measured)` DEcreases toward the sample, as in the JPK export: it
        // falls 146.11 -> 126.15 µm during the approach (segment 1) while the force rises
        // from -117 to +206 nN. A repulsive F bends the cantilever up by F/k, so the tip
        // is at z = height + F/k (nanite's `compute_tip_position` uses the same, and it
        // reproduces JPK's "Vertical Tip Position") and x = -z. The hold (segment 2)
        // decides the sign: the base height is constant (126.1049 µm) while the force
        // relaxes 207 -> -0.5 nN; with +F/k the tip sinks 0.19 µm INTO the cell as the
        // cantilever unloads (physical), with −F/k it would rise out of it.
        samples.push(line, t, -(height + force / k), force)?;
        segment_ids.push(segment);
    }

    let names = segment_names(&metadata, &segment_ids);
    let labels: Vec<Option<String>> = segment_ids
        .iter()
        .map(|id| id.map(|id| name_of(&names, id)))
        .collect();
    let segments = segments_from_labels(&labels);
    let mode = metadata
        .get("imaging mode")
        .and_then(|m| m.as_str())
        .unwrap_or("unknown");
    let mut notes = vec![
        format!("force = `{FORCE}` [N], raw: the baseline offset is not removed"),
        format!("time = `{TIME}` [s]"),
        format!(
            "tip position into the material = -(`{HEIGHT}` + {FORCE}/k), k = {} N/m from the \
             metadata `{SPRING_CONSTANT}`{}; the height decreases toward the \
             sample and the deflection F/k lifts the tip above it",
            short(k),
            k_line.map_or_else(String::new, |l| format!(" (line {l})"))
        ),
    ];
    if i_seg.is_some() {
        let described: Vec<String> = names
            .iter()
            .enumerate()
            .map(|(i, n)| format!("{i} = {n}"))
            .collect();
        notes.push(format!(
            "segments from the `{SEGMENT}` column, imaging mode `{mode}`: {}",
            described.join(", ")
        ));
    }
    samples.finish(Some(header_line), Format::AfmTab, segments, notes)
}

/// The JSON between `# BEGIN METADATA` and `# END METADATA`.
fn parse_metadata(path: &Path, comments: &[(usize, &str)]) -> Result<serde_json::Value, ReadError> {
    let begin = comments
        .iter()
        .position(|(_, c)| c.trim() == "BEGIN METADATA");
    let end = comments
        .iter()
        .position(|(_, c)| c.trim() == "END METADATA");
    let (Some(begin), Some(end)) = (begin, end) else {
        return Err(ReadError::file(
            path,
            ReadErrorKind::Invalid("no `# BEGIN METADATA` ... `# END METADATA` block".into()),
        ));
    };
    let body = comments.get(begin + 1..end).unwrap_or(&[]);
    let json: Vec<&str> = body.iter().map(|(_, c)| *c).collect();
    let begin_line = comments.get(begin).map_or(1, |(l, _)| *l);
    serde_json::from_str(&json.join("\n")).map_err(|e| {
        // serde_json counts lines from 1 within the joined body.
        let line = body
            .get(e.line().saturating_sub(1))
            .map_or(begin_line, |(l, _)| *l);
        ReadError::at(
            path,
            line,
            Some("metadata"),
            ReadErrorKind::Invalid(format!("invalid JSON: {e}")),
        )
    })
}

/// `"spring constant"` \[N/m\] from the metadata, finite and > 0, with the physical line
/// that holds it (when found).
fn spring_constant(
    path: &Path,
    metadata: &serde_json::Value,
    comments: &[(usize, &str)],
) -> Result<(f64, Option<usize>), ReadError> {
    let key = format!("{SPRING_CONSTANT:?}");
    let line = comments
        .iter()
        .find(|(_, c)| c.contains(&key))
        .map(|(l, _)| *l);
    let invalid = |message: String| ReadError {
        path: path.to_path_buf(),
        line,
        field: Some(SPRING_CONSTANT.to_owned()),
        kind: ReadErrorKind::Invalid(message),
    };
    let value = metadata
        .get(SPRING_CONSTANT)
        .ok_or_else(|| invalid("missing from the metadata".into()))?;
    match value.as_f64() {
        Some(k) if k.is_finite() && k > 0.0 => Ok((k, line)),
        _ => Err(invalid(format!("must be a number > 0 N/m, got {value}"))),
    }
}

/// A `segment` cell: a non-negative integer (written as a float by afmformats).
fn segment_index(path: &Path, line: usize, text: &str) -> Result<u32, ReadError> {
    let value = parse_cell(path, line, SEGMENT, text)?;
    if value >= 0.0 && value.fract() == 0.0 && value <= f64::from(u16::MAX) {
        Ok(value as u32)
    } else {
        Err(ReadError::at(
            path,
            line,
            Some(SEGMENT),
            ReadErrorKind::Invalid(format!(
                "segment index must be an integer in 0..={}, got {:?}",
                u16::MAX,
                text.trim()
            )),
        ))
    }
}

/// Names for segment indices `0..=max`: from the imaging mode when the number of
/// segments matches its known layout, else `segment <i>`.
fn segment_names(metadata: &serde_json::Value, ids: &[Option<u32>]) -> Vec<String> {
    let count = ids.iter().flatten().max().map_or(0, |&m| m as usize + 1);
    let mode = metadata.get("imaging mode").and_then(|m| m.as_str());
    let known: &[&str] = match (mode, count) {
        (Some("force-distance"), 2) => &["approach", "retract"],
        (Some("creep-compliance" | "stress-relaxation"), 3) => &["approach", "hold", "retract"],
        // afmformats puts a pause at the start (constant height) before the approach.
        (Some("creep-compliance" | "stress-relaxation"), 4) => {
            &["pre-pause", "approach", "hold", "retract"]
        }
        _ => &[],
    };
    (0..count)
        .map(|i| {
            known
                .get(i)
                .map_or_else(|| format!("segment {i}"), |s| (*s).to_owned())
        })
        .collect()
}

fn name_of(names: &[String], id: u32) -> String {
    names
        .get(id as usize)
        .cloned()
        .unwrap_or_else(|| format!("segment {id}"))
}
