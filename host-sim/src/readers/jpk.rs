//! JPK "TEXT EXPORT" of an AFM force curve (JPK CellHesion / NanoWizard software).
//!
//! `#` header lines, then one block per segment, each opened by `# segment: <name>`
//! (extend, pause, retract) and followed by `# columns: ...`, `# units: ...` and
//! `# springConstant: <k>`; rows are whitespace-separated floats; CRLF line ends. The
//! columns differ between segments, so they are looked up by name in every block.
//!
//! Conversions (checked against afm/brain-creep-jpk.txt, see the `read` comments):
//! - force = `vDeflection` \[N\], raw (the baseline offset is kept);
//! - time = `seriesTime` \[s\] (continuous; `time` restarts in every segment);
//! - position into the material x = −(measuredHeight + vDeflection / k).

use std::path::Path;

use super::error::{ReadError, ReadErrorKind};
use super::text::{
    cell, check_row_length, decode_utf8_or_latin1, find_columns, lines, parse_cell, short, Samples,
};
use crate::record::{Format, Record, Segment};

const TIME: &str = "seriesTime";
const HEIGHT: &str = "measuredHeight";
const FORCE: &str = "vDeflection";

/// What the `#` lines of the current segment block have declared so far.
struct Block {
    name: String,
    line: usize,
    start: usize,
    columns: Option<(usize, Vec<String>)>,
    units: Option<(usize, Vec<String>)>,
    spring_constant: Option<f64>,
    declared_points: Option<(usize, usize)>,
    /// `\[time, height, force\]` column indices and k, resolved at the first data row.
    resolved: Option<([usize; 3], f64)>,
}

pub(crate) fn read(bytes: &[u8], path: &Path) -> Result<Record, ReadError> {
    let text = decode_utf8_or_latin1(bytes);
    let mut samples = Samples::new(path, TIME, HEIGHT, FORCE);
    let mut blocks: Vec<Block> = Vec::new();
    let mut file_k: Option<f64> = None;
    let mut last_header_line = None;

    for (line, raw) in lines(&text) {
        let trimmed = raw.trim();
        if trimmed.is_empty() {
            continue;
        }
        if let Some(comment) = trimmed.strip_prefix('#') {
            last_header_line = Some(line);
            let Some((key, value)) = comment.split_once(':') else {
                continue;
            };
            let (key, value) = (key.trim(), value.trim());
            if key == "segment" {
                if let Some(previous) = blocks.last() {
                    check_point_count(path, previous, samples.len())?;
                }
                blocks.push(Block {
                    name: value.to_owned(),
                    line,
                    start: samples.len(),
                    columns: None,
                    units: None,
                    spring_constant: None,
                    declared_points: None,
                    resolved: None,
                });
                continue;
            }
            let names = || value.split_whitespace().map(str::to_owned).collect();
            match (key, blocks.last_mut()) {
                ("columns", Some(b)) => b.columns = Some((line, names())),
                ("units", Some(b)) => b.units = Some((line, names())),
                ("recorded-num-points", Some(b)) => {
                    b.declared_points = value.parse().ok().map(|n| (line, n));
                }
                ("springConstant", block) => {
                    let k = parse_cell(path, line, "springConstant", value)?;
                    if k <= 0.0 {
                        return Err(ReadError::at(
                            path,
                            line,
                            Some("springConstant"),
                            ReadErrorKind::Invalid(format!("must be > 0 N/m, got {value}")),
                        ));
                    }
                    match block {
                        Some(b) => b.spring_constant = Some(k),
                        None => file_k = Some(k),
                    }
                }
                _ => {}
            }
            continue;
        }

        let Some(block) = blocks.last_mut() else {
            return Err(ReadError::at(
                path,
                line,
                Some("segment"),
                ReadErrorKind::Invalid("data row before any `# segment:` header line".into()),
            ));
        };
        let ([it, ih, i_f], k) = match block.resolved {
            Some(r) => r,
            None => {
                let r = resolve(path, block, file_k, line)?;
                block.resolved = Some(r);
                r
            }
        };
        let n_columns = block.columns.as_ref().map_or(0, |(_, c)| c.len());
        let cells: Vec<&str> = trimmed.split_whitespace().collect();
        check_row_length(
            path,
            line,
            cells.len(),
            n_columns,
            block.columns.as_ref().map_or(block.line, |(l, _)| *l),
        )?;
        let t = parse_cell(path, line, TIME, cell(&cells, it))?;
        let height = parse_cell(path, line, HEIGHT, cell(&cells, ih))?;
        let force = parse_cell(path, line, FORCE, cell(&cells, i_f))?;
        // measuredHeight is the height of the cantilever base (piezo, from its sensor);
        // it DEcreases toward the sample (47.4 -> 17.4 µm during the extend). A
        // repulsive force F > 0 bends the cantilever up by F/k, so the tip sits at
        // z = measuredHeight + F/k and the position INTO the material is x = -z.
        // Check: the indentation δ = (h_c − h) − (F − F0)/k of the data README is
        // x − x_c; during the pause (force clamp) h creeps 17.399 -> 15.820 µm at a
        // constant F, so x rises by 1.58 µm (creep into the material).
        samples.push(line, t, -(height + force / k), force)?;
    }

    if let Some(last) = blocks.last() {
        check_point_count(path, last, samples.len())?;
    }
    let n = samples.len();
    let segments: Vec<Segment> = blocks
        .iter()
        .enumerate()
        .map(|(i, b)| Segment {
            name: b.name.clone(),
            start: b.start,
            end: blocks.get(i + 1).map_or(n, |next| next.start),
        })
        .collect();
    let notes = notes(&blocks);
    samples.finish(last_header_line, Format::Jpk, segments, notes)
}

/// Column indices and spring constant of a block, checked at its first data row.
fn resolve(
    path: &Path,
    block: &Block,
    file_k: Option<f64>,
    line: usize,
) -> Result<([usize; 3], f64), ReadError> {
    let Some((columns_line, columns)) = &block.columns else {
        return Err(ReadError::at(
            path,
            line,
            Some("columns"),
            ReadErrorKind::Invalid(format!(
                "data row before the `# columns:` line of segment `{}` (line {})",
                block.name, block.line
            )),
        ));
    };
    let indices = find_columns(path, Some(*columns_line), columns, &[TIME, HEIGHT, FORCE])?;
    if let Some((units_line, units)) = &block.units {
        for (index, expected) in indices.iter().zip(["s", "m", "N"]) {
            let found = units.get(*index).map_or("", String::as_str);
            if found != expected {
                let name = columns.get(*index).map_or("", String::as_str);
                return Err(ReadError::at(
                    path,
                    *units_line,
                    Some(name),
                    ReadErrorKind::Invalid(format!("unit `{found}`, expected `{expected}`")),
                ));
            }
        }
    }
    let k = block.spring_constant.or(file_k).ok_or_else(|| {
        ReadError::at(
            path,
            block.line,
            Some("springConstant"),
            ReadErrorKind::Invalid(format!("missing in the header of segment `{}`", block.name)),
        )
    })?;
    Ok((indices, k))
}

/// `recorded-num-points` of a block against the rows read for it.
fn check_point_count(path: &Path, block: &Block, n_total: usize) -> Result<(), ReadError> {
    let found = n_total.saturating_sub(block.start);
    match block.declared_points {
        Some((line, declared)) if declared != found => Err(ReadError::at(
            path,
            line,
            Some("recorded-num-points"),
            ReadErrorKind::PointCount {
                declared,
                found,
                first_line: None,
                last_line: None,
            },
        )),
        _ => Ok(()),
    }
}

fn notes(blocks: &[Block]) -> Vec<String> {
    let mut ks: Vec<String> = Vec::new();
    for b in blocks {
        if let Some((_, k)) = b.resolved {
            let k = format!("{} N/m", short(k));
            if !ks.contains(&k) {
                ks.push(k);
            }
        }
    }
    vec![
        format!("force = {FORCE} [N], raw: the baseline offset is not removed"),
        format!("time = {TIME} [s], continuous across segments (`time` restarts in each)"),
        format!(
            "tip position into the material = -({HEIGHT} + {FORCE}/k), k = {} from the \
             segment headers (springConstant); {HEIGHT} decreases toward the sample and the \
             deflection F/k lifts the tip above it",
            ks.join(", ")
        ),
    ]
}
