//! The project's own log format: CSV with header `time_s,position_m,force_n` in SI, any
//! column order, extra columns ignored, `#` comment lines allowed. An optional `segment`
//! column (written by [`Record::write_csv`](crate::record::Record::write_csv)) gives each
//! sample's segment name; runs of equal names become segments.
//!
//! Streamed in blocks of [`BLOCK_BYTES`]: the rows of a block are parsed in parallel
//! pieces cut at line breaks, then checked and appended in file order (a 600 s, 1 kHz log
//! is read in the memory of its three columns, one block and the block's parsed rows).

use std::io::{BufRead, Read};
use std::path::Path;

use rayon::prelude::*;

use super::error::{ReadError, ReadErrorKind};
use super::text::{
    check_row_length, find_columns, parse_field, CsvLines, Samples, SegmentRuns, SliceLines,
};
use crate::record::{Format, Record};

const COLUMNS: [&str; 3] = ["time_s", "position_m", "force_n"];

/// Bytes read at a time; their rows are parsed in parallel.
const BLOCK_BYTES: usize = 4 << 20;

/// Pieces a block is parsed in (a few per thread, for an even load).
const PIECES: usize = 16;

/// The columns of a table: where each is in a row, and the row's length.
#[derive(Clone, Copy)]
struct Layout<'p> {
    path: &'p Path,
    time: usize,
    position: usize,
    force: usize,
    segment: Option<usize>,
    width: usize,
    header_line: usize,
}

/// The rows of one piece of a block, parsed and checked ([`Samples::check`], each against
/// the row before it in the piece): up to its first malformed row, whose error is kept
/// for when the rows before it have been added. Reused from block to block (no fresh
/// pages for every block's rows).
#[derive(Default)]
struct Piece {
    time: Vec<f64>,
    position: Vec<f64>,
    force: Vec<f64>,
    /// Lines of the first and the last row.
    lines: Option<(usize, usize)>,
    /// `segment` labels back to back, and where each row's ends.
    labels: Vec<u8>,
    label_ends: Vec<usize>,
    error: Option<ReadError>,
}

impl Piece {
    /// Parses `bytes`, the file's lines after line `after`, in place of what it held.
    fn parse(&mut self, bytes: &[u8], after: usize, layout: Layout<'_>, samples: &Samples<'_>) {
        for column in [&mut self.time, &mut self.position, &mut self.force] {
            column.clear();
        }
        self.lines = None;
        self.labels.clear();
        self.label_ends.clear();
        self.error = self.parse_rows(bytes, after, layout, samples).err();
    }

    fn parse_rows(
        &mut self,
        bytes: &[u8],
        after: usize,
        layout: Layout<'_>,
        samples: &Samples<'_>,
    ) -> Result<(), ReadError> {
        let Layout { path, .. } = layout;
        let mut rows = SliceLines::after_line(bytes, after);
        while rows.advance() {
            let line = rows.line_number();
            check_row_length(path, line, rows.len(), layout.width, layout.header_line)?;
            let t = parse_field(path, line, "time_s", rows.field(layout.time))?;
            let x = parse_field(path, line, "position_m", rows.field(layout.position))?;
            let f = parse_field(path, line, "force_n", rows.field(layout.force))?;
            let previous = self
                .time
                .last()
                .copied()
                .zip(self.lines.map(|(_, last)| last));
            samples.check(line, [t, x, f], previous)?;
            self.time.push(t);
            self.position.push(x);
            self.force.push(f);
            self.lines = Some((self.lines.map_or(line, |(first, _)| first), line));
            if let Some(i) = layout.segment {
                self.labels.extend_from_slice(rows.field(i));
                self.label_ends.push(self.labels.len());
            }
        }
        Ok(())
    }

    /// Appends the rows in order, then reports the piece's error if it has one.
    fn append(
        &mut self,
        samples: &mut Samples<'_>,
        segments: &mut SegmentRuns,
    ) -> Result<(), ReadError> {
        if let Some(lines) = self.lines {
            samples.extend_checked(lines, &self.time, &self.position, &self.force)?;
        }
        let mut start = 0;
        for &end in &self.label_ends {
            segments.push(&self.labels[start..end]);
            start = end;
        }
        self.error.take().map_or(Ok(()), Err)
    }
}

/// Parses `block` (whole lines, the file's lines after line `after`) in parallel pieces
/// (`parsed` holds them) and appends its rows in file order; returns the number of its
/// last line.
fn read_block(
    block: &[u8],
    after: usize,
    layout: Layout<'_>,
    parsed: &mut [Piece; PIECES],
    samples: &mut Samples<'_>,
    segments: &mut SegmentRuns,
) -> Result<usize, ReadError> {
    // Pieces cut after a line break, each with the number of the line before it.
    let mut pieces = Vec::with_capacity(PIECES);
    let (mut start, mut line) = (0, after);
    while start < block.len() {
        let target = (start + block.len().div_ceil(PIECES)).min(block.len());
        let end = memchr::memchr(b'\n', &block[target..]).map_or(block.len(), |i| target + i + 1);
        pieces.push((&block[start..end], line));
        line += memchr::memchr_iter(b'\n', &block[start..end]).count();
        start = end;
    }
    let parsed = &mut parsed[..pieces.len()];
    let checked: &Samples<'_> = samples;
    parsed
        .par_iter_mut()
        .zip(pieces)
        .for_each(|(piece, (bytes, after))| piece.parse(bytes, after, layout, checked));
    for piece in parsed {
        piece.append(samples, segments)?;
    }
    Ok(line)
}

/// `expected`: the expected number of samples, to size the columns (0: unknown).
pub(crate) fn read(input: impl BufRead, path: &Path, expected: usize) -> Result<Record, ReadError> {
    read_in_blocks(input, path, expected, BLOCK_BYTES)
}

/// [`read`] in blocks of `block_bytes` (a parameter so that tests can cross block edges
/// with small inputs).
fn read_in_blocks(
    input: impl BufRead,
    path: &Path,
    expected: usize,
    block_bytes: usize,
) -> Result<Record, ReadError> {
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
    let layout = Layout {
        path,
        time: it,
        position: ix,
        force: i_f,
        segment: i_seg,
        width: header.len(),
        header_line,
    };

    let mut samples = Samples::new(path, "time_s", "position_m", "force_n");
    samples.reserve(expected);
    let mut segments = SegmentRuns::default();
    let (mut input, mut line) = rows.into_parts();
    let mut block = Vec::with_capacity(block_bytes);
    let mut carry = Vec::new();
    let mut parsed: [Piece; PIECES] = Default::default();
    loop {
        block.clear();
        block.append(&mut carry);
        let wanted = block_bytes as u64;
        let read = (&mut input).take(wanted).read_to_end(&mut block);
        let end_of_input = !matches!(read, Ok(n) if n as u64 == wanted);
        if !end_of_input {
            // Whole lines now, the rest with the next block (a line longer than a block
            // waits for its end).
            match block.iter().rposition(|&b| b == b'\n') {
                Some(i) => carry.extend_from_slice(&block[i + 1..]),
                None => {
                    carry.append(&mut block);
                    continue;
                }
            }
            block.truncate(block.len() - carry.len());
        } else if read.is_err() {
            // The whole lines before a failed read are checked first, as a line by line
            // reader would.
            let whole = block.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
            block.truncate(whole);
        }
        line = read_block(
            &block,
            line,
            layout,
            &mut parsed,
            &mut samples,
            &mut segments,
        )?;
        if end_of_input {
            read.map_err(io)?;
            break;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A log of `rows` rows over several blocks: a comment, a blank line and a segment
    /// change on the way, time `i` ms, position `i` µm, force `2i`.
    fn log(rows: usize) -> String {
        let mut text = String::from("# a log\ntime_s,position_m,force_n,segment\n");
        for i in 0..rows {
            if i == rows / 3 {
                text.push_str("# halfway\n\n");
            }
            let segment = if i < rows / 2 { "a" } else { "b" };
            text.push_str(&format!("{}e-3,{}e-6,{},{segment}\n", i, i, 2 * i));
        }
        text
    }

    #[test]
    fn rows_over_several_blocks_keep_their_order_lines_and_segments() {
        let rows = 400_000;
        let text = log(rows);
        assert!(text.len() > 2 * BLOCK_BYTES);
        let record = read(text.as_bytes(), Path::new("log.csv"), 0).unwrap();
        assert_eq!(record.len(), rows);
        for i in [0, 1, rows / 3, rows / 2, rows - 1] {
            assert_eq!(record.time_s[i], format!("{i}e-3").parse::<f64>().unwrap());
            assert_eq!(record.force_n[i], (2 * i) as f64);
        }
        let names: Vec<_> = record
            .segments
            .iter()
            .map(|s| (&s.name[..], s.range()))
            .collect();
        assert_eq!(names, [("a", 0..rows / 2), ("b", rows / 2..rows)]);
    }

    #[test]
    fn an_error_late_in_a_long_file_names_its_physical_line() {
        let rows = 400_000;
        // Data row i is on line i + 3 before the comment and blank line at rows / 3, on
        // line i + 5 after them.
        for (row, bad, message) in [
            (
                rows / 4,
                "x",
                "log.csv:100003: field `position_m`: not a number",
            ),
            (
                rows - 10,
                "x",
                "log.csv:399995: field `position_m`: not a number",
            ),
            (rows / 2 + 7, "-1e-6", "log.csv:200012: field `time_s`"),
        ] {
            let text = log(rows);
            let old = format!("\n{}e-3,{}e-6,", row, row);
            let new = if bad == "x" {
                format!("\n{}e-3,x,", row)
            } else {
                format!("\n{bad},{}e-6,", row)
            };
            let text = text.replacen(&old, &new, 1);
            let error = read(text.as_bytes(), Path::new("log.csv"), 0).unwrap_err();
            assert!(error.to_string().starts_with(message), "{error}");
        }
    }

    /// Every block size, from smaller than one line to the whole file, reads the same
    /// rows, line numbers and segments as one block: CRLF line ends cut at any byte, a
    /// line longer than a block, no line break at the end.
    #[test]
    fn any_block_size_reads_the_same_record() {
        let mut text = log(300).replace('\n', "\r\n");
        text.push_str("0.3,3e-4,600,b");
        let whole = read_in_blocks(text.as_bytes(), Path::new("log.csv"), 0, 1 << 20).unwrap();
        assert_eq!(whole.len(), 301);
        for block_bytes in [1, 7, 20, 64, 1000] {
            let record =
                read_in_blocks(text.as_bytes(), Path::new("log.csv"), 0, block_bytes).unwrap();
            assert_eq!(record.time_s, whole.time_s, "{block_bytes}");
            assert_eq!(record.position_m, whole.position_m, "{block_bytes}");
            assert_eq!(record.force_n, whole.force_n, "{block_bytes}");
            assert_eq!(record.segments, whole.segments, "{block_bytes}");
        }
        let bad = text.replacen("\r\n250e-3,", "\r\n250e-3x,", 1);
        for block_bytes in [7, 64, 1 << 20] {
            let error = read_in_blocks(bad.as_bytes(), Path::new("log.csv"), 0, block_bytes)
                .unwrap_err()
                .to_string();
            assert!(
                error.starts_with("log.csv:255: field `time_s`"),
                "{block_bytes}: {error}"
            );
        }
    }

    /// A reader that fails part-way: the whole lines before the failure are checked
    /// first (a bad row there is reported as such), then the I/O error is reported.
    #[test]
    fn a_read_failing_mid_file_reports_the_io_error_after_the_rows_before_it() {
        struct Failing<'a>(&'a [u8]);
        impl std::io::Read for Failing<'_> {
            fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
                if self.0.is_empty() {
                    return Err(std::io::Error::other("disk gone"));
                }
                let n = out.len().min(self.0.len());
                out[..n].copy_from_slice(&self.0[..n]);
                self.0 = &self.0[n..];
                Ok(n)
            }
        }
        // The error of reading the first half of `text`, then failing.
        let read_half = |text: &str| {
            let half = Failing(&text.as_bytes()[..text.len() / 2]);
            read_in_blocks(std::io::BufReader::new(half), Path::new("log.csv"), 0, 64)
                .unwrap_err()
                .to_string()
        };
        let text = log(100);
        let error = read_half(&text);
        assert!(error.contains("disk gone"), "{error}");
        let error = read_half(&text.replacen("\n10e-3,", "\n10e-3x,", 1));
        assert!(error.starts_with("log.csv:13: field `time_s`"), "{error}");
    }
}
