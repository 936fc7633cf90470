//! Helpers shared by the readers: byte decoding, physical lines, number cells, unit
//! suffixes, and the sample accumulator that enforces the [`Record`] invariants.

use std::path::Path;

use super::error::{ReadError, ReadErrorKind};
use crate::record::{Format, Record, Segment};

/// Decodes bytes as UTF-8 when they are valid UTF-8 (dropping a byte-order mark), else
/// as Latin-1 (ISO-8859-1: every byte is the char with that code point). Never fails.
pub(crate) fn decode_utf8_or_latin1(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(s) => s.strip_prefix('\u{feff}').unwrap_or(s).to_owned(),
        Err(_) => decode_latin1(bytes),
    }
}

/// Decodes bytes as Latin-1 (ISO-8859-1): each byte becomes the char with that code
/// point. Never fails.
pub(crate) fn decode_latin1(bytes: &[u8]) -> String {
    bytes.iter().map(|&b| char::from(b)).collect()
}

/// The physical lines of `text` as `(1-based line number, line)`, split on `\n` with a
/// trailing `\r` removed (CRLF files).
pub(crate) fn lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
}

/// Checks that a data row has as many cells as its header (`expected` columns, header
/// on `header_line`); a mismatch is a [`ReadErrorKind::RowLength`] at `line`.
pub(crate) fn check_row_length(
    path: &Path,
    line: usize,
    found: usize,
    expected: usize,
    header_line: usize,
) -> Result<(), ReadError> {
    if found == expected {
        return Ok(());
    }
    Err(ReadError::at(
        path,
        line,
        None,
        ReadErrorKind::RowLength {
            expected,
            found,
            header_line,
        },
    ))
}

/// Cell `i` of a row, `""` past its end.
pub(crate) fn cell<S: AsRef<str>>(cells: &[S], i: usize) -> &str {
    cells.get(i).map_or("", AsRef::as_ref)
}

/// Parses one numeric cell; the error names the line, the column and quotes the text.
pub(crate) fn parse_cell(
    path: &Path,
    line: usize,
    column: &str,
    text: &str,
) -> Result<f64, ReadError> {
    let text = text.trim();
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(ReadError::at(
            path,
            line,
            Some(column),
            ReadErrorKind::NonFinite {
                text: text.to_owned(),
            },
        )),
        Err(_) => Err(ReadError::at(
            path,
            line,
            Some(column),
            ReadErrorKind::NonNumeric {
                text: text.to_owned(),
            },
        )),
    }
}

/// Indices of the `expected` columns in `header` (exact names); a missing one is a
/// [`ReadErrorKind::MissingColumn`] naming it, all expected and all found columns.
pub(crate) fn find_columns<const N: usize>(
    path: &Path,
    header_line: Option<usize>,
    header: &[String],
    expected: &[&str; N],
) -> Result<[usize; N], ReadError> {
    let mut indices = [0; N];
    for (index, name) in indices.iter_mut().zip(expected) {
        *index = header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| ReadError {
                path: path.to_path_buf(),
                line: header_line,
                field: Some((*name).to_owned()),
                kind: ReadErrorKind::MissingColumn {
                    expected: expected.iter().map(|s| (*s).to_owned()).collect(),
                    found: header.to_vec(),
                },
            })?;
    }
    Ok(indices)
}

/// A column header of the form `Name (unit)` split into `("Name", "unit")`.
pub(crate) fn split_unit(header: &str) -> Option<(&str, &str)> {
    let inner = header.trim().strip_suffix(')')?;
    let open = inner.rfind(" (")?;
    Some((inner.get(..open)?, inner.get(open + 2..)?))
}

/// Finds the column `Name (unit)` whose name is `name` and whose unit is one of `units`
/// (`(unit, factor to SI)`); returns its index, full header text and SI factor.
pub(crate) fn find_unit_column<'h>(
    header: &'h [String],
    name: &str,
    units: &[(&str, f64)],
) -> Option<(usize, &'h str, f64)> {
    header.iter().enumerate().find_map(|(i, h)| {
        let (n, u) = split_unit(h)?;
        // A UTF-8 `µ` read as Latin-1 is `Âµ`; the Greek `μ` is also used for micro.
        let u = u.replace("Âµ", "µ").replace('μ', "µ");
        let factor = units.iter().find(|(unit, _)| *unit == u)?.1;
        (n == name).then_some((i, h.as_str(), factor))
    })
}

/// Length units to metres.
pub(crate) const LENGTH_UNITS: &[(&str, f64)] = &[
    ("m", 1.0),
    ("mm", 1e-3),
    ("µm", 1e-6),
    ("um", 1e-6),
    ("nm", 1e-9),
];
/// Force units to newtons.
pub(crate) const FORCE_UNITS: &[(&str, f64)] = &[
    ("kN", 1e3),
    ("N", 1.0),
    ("mN", 1e-3),
    ("µN", 1e-6),
    ("uN", 1e-6),
    ("nN", 1e-9),
];
/// Time units to seconds.
pub(crate) const TIME_UNITS: &[(&str, f64)] = &[("s", 1.0), ("ms", 1e-3), ("min", 60.0)];

/// Formats a value with at most 6 significant digits for notes (`0.061`, `1.0677`).
/// Very small or large magnitudes use exponent notation (`1e-9`).
pub(crate) fn short(x: f64) -> String {
    let rounded = format!("{x:.5e}").parse::<f64>().unwrap_or(x);
    let magnitude = rounded.abs();
    if magnitude != 0.0 && !(1e-3..1e6).contains(&magnitude) {
        format!("{rounded:e}")
    } else {
        rounded.to_string()
    }
}

/// Accumulates samples, checking on the way that every value is finite and that time
/// strictly increases, and builds the [`Record`].
pub(crate) struct Samples<'p> {
    path: &'p Path,
    time_field: String,
    position_field: String,
    force_field: String,
    time_s: Vec<f64>,
    position_m: Vec<f64>,
    force_n: Vec<f64>,
    last_line: Option<usize>,
}

impl<'p> Samples<'p> {
    /// `*_field` name the file's columns the values come from, for error messages.
    pub(crate) fn new(
        path: &'p Path,
        time_field: &str,
        position_field: &str,
        force_field: &str,
    ) -> Self {
        Samples {
            path,
            time_field: time_field.to_owned(),
            position_field: position_field.to_owned(),
            force_field: force_field.to_owned(),
            time_s: Vec::new(),
            position_m: Vec::new(),
            force_n: Vec::new(),
            last_line: None,
        }
    }

    /// Room for `rows` samples (an estimate; the columns still grow past it).
    pub(crate) fn reserve(&mut self, rows: usize) {
        self.time_s.reserve_exact(rows);
        self.position_m.reserve_exact(rows);
        self.force_n.reserve_exact(rows);
    }

    /// Number of samples so far.
    pub(crate) fn len(&self) -> usize {
        self.time_s.len()
    }

    /// Checks one sample read on `line` (values already in SI and in the record's sign
    /// convention) against the record's invariants: every value finite and within the
    /// estimator's range, and a time that exceeds the sample before, `previous` (time and
    /// line), if there is one. Does not add it: a reader may check rows in parallel
    /// pieces ([`Samples::extend_checked`]).
    pub(crate) fn check(
        &self,
        line: usize,
        [time_s, position_m, force_n]: [f64; 3],
        previous: Option<(f64, usize)>,
    ) -> Result<(), ReadError> {
        for (value, field, unit) in [
            (time_s, &self.time_field, "s"),
            (position_m, &self.position_field, "m"),
            (force_n, &self.force_field, "N"),
        ] {
            let out_of_range = if value.abs() > f64::from(f32::MAX) {
                Some("overflows f32 (|x| ≤ 3.4e38): the estimator core computes in f32")
            } else if unit != "s"
                && value.abs() > f64::from(estimator_core::pipeline::MAX_ABS_INPUT)
            {
                Some("is beyond the estimator's input range (|x| ≤ 1e6 in SI): check the file's unit")
            } else {
                None
            };
            if let (Some(reason), true) = (out_of_range, value.is_finite()) {
                return Err(ReadError::at(
                    self.path,
                    line,
                    Some(field),
                    ReadErrorKind::OutOfRange {
                        value,
                        unit,
                        reason,
                    },
                ));
            }
            if !value.is_finite() {
                return Err(ReadError::at(
                    self.path,
                    line,
                    Some(field),
                    ReadErrorKind::NonFinite {
                        text: format!("{value} after conversion to SI"),
                    },
                ));
            }
        }
        match previous {
            Some((previous, previous_line)) if time_s <= previous => {
                Err(self.time_not_increasing(line, time_s, previous, previous_line))
            }
            _ => Ok(()),
        }
    }

    fn time_not_increasing(
        &self,
        line: usize,
        value: f64,
        previous: f64,
        previous_line: usize,
    ) -> ReadError {
        ReadError::at(
            self.path,
            line,
            Some(&self.time_field),
            ReadErrorKind::TimeNotIncreasing {
                value,
                previous,
                previous_line,
            },
        )
    }

    /// The last sample's time and line.
    pub(crate) fn last(&self) -> Option<(f64, usize)> {
        self.time_s.last().copied().zip(self.last_line)
    }

    /// Adds one sample read on `line` after [`Samples::check`]ing it.
    pub(crate) fn push(
        &mut self,
        line: usize,
        time_s: f64,
        position_m: f64,
        force_n: f64,
    ) -> Result<(), ReadError> {
        self.check(line, [time_s, position_m, force_n], self.last())?;
        self.time_s.push(time_s);
        self.position_m.push(position_m);
        self.force_n.push(force_n);
        self.last_line = Some(line);
        Ok(())
    }

    /// Adds consecutive rows, read on lines `lines` (first, last), that were each
    /// [`Samples::check`]ed against the row before them but the first; the first is
    /// checked here against the last sample.
    pub(crate) fn extend_checked(
        &mut self,
        (first_line, last_line): (usize, usize),
        time_s: &[f64],
        position_m: &[f64],
        force_n: &[f64],
    ) -> Result<(), ReadError> {
        if let (Some(&first), Some((previous, previous_line))) = (time_s.first(), self.last()) {
            if first <= previous {
                return Err(self.time_not_increasing(first_line, first, previous, previous_line));
            }
        }
        if time_s.is_empty() {
            return Ok(());
        }
        self.time_s.extend_from_slice(time_s);
        self.position_m.extend_from_slice(position_m);
        self.force_n.extend_from_slice(force_n);
        self.last_line = Some(last_line);
        Ok(())
    }

    /// The record; [`ReadErrorKind::NoData`] (at `header_line`) without samples,
    /// [`ReadErrorKind::TooFewSamples`] with one.
    pub(crate) fn finish(
        self,
        header_line: Option<usize>,
        format: Format,
        segments: Vec<Segment>,
        notes: Vec<String>,
    ) -> Result<Record, ReadError> {
        match self.time_s.len() {
            0 => Err(ReadError {
                path: self.path.to_path_buf(),
                line: header_line,
                field: None,
                kind: ReadErrorKind::NoData,
            }),
            1 => Err(ReadError {
                path: self.path.to_path_buf(),
                line: self.last_line,
                field: None,
                kind: ReadErrorKind::TooFewSamples { found: 1 },
            }),
            _ => Ok(Record {
                time_s: self.time_s,
                position_m: self.position_m,
                force_n: self.force_n,
                source: self.path.to_path_buf(),
                format,
                segments,
                notes,
            }),
        }
    }
}

/// Segments from per-sample labels: each maximal run of equal labels becomes one
/// segment; samples labelled `None` belong to no segment.
pub(crate) fn segments_from_labels(labels: &[Option<String>]) -> Vec<Segment> {
    let mut segments: Vec<Segment> = Vec::new();
    let mut current: Option<(usize, &str)> = None;
    for (i, label) in labels.iter().enumerate() {
        let label = label.as_deref();
        match (current, label) {
            (Some((_, name)), Some(l)) if name == l => {}
            _ => {
                if let Some((start, name)) = current.take() {
                    segments.push(Segment {
                        name: name.to_owned(),
                        start,
                        end: i,
                    });
                }
                current = label.map(|l| (i, l));
            }
        }
    }
    if let Some((start, name)) = current {
        segments.push(Segment {
            name: name.to_owned(),
            start,
            end: labels.len(),
        });
    }
    segments
}

/// One physical line split into its fields by `csv-core` (the `csv` crate's parser; `""`
/// inside quotes is a quote): the unquoted field bytes back to back and where each ends.
/// The buffers are reused from line to line (no allocation per row).
struct Fields {
    parser: csv_core::Reader,
    /// Unquoted field bytes of the current record, back to back.
    bytes: Vec<u8>,
    /// End offset in `bytes` of each field.
    ends: Vec<usize>,
    count: usize,
}

impl Fields {
    fn new() -> Self {
        Fields {
            parser: csv_core::Reader::new(),
            bytes: vec![0; 256],
            ends: vec![0; 16],
            count: 0,
        }
    }

    /// Splits `line` (growing the buffers when a line needs more room).
    fn split(&mut self, line: &[u8]) {
        use csv_core::ReadRecordResult as R;
        self.parser.reset();
        let (mut consumed, mut written, mut count) = (0, 0, 0);
        let mut finishing = false;
        loop {
            let input: &[u8] = if finishing { &[] } else { &line[consumed..] };
            let (result, nin, nout, nend) =
                self.parser
                    .read_record(input, &mut self.bytes[written..], &mut self.ends[count..]);
            // csv-core counts field ends from the start of the record, across calls.
            consumed += nin;
            written += nout;
            count += nend;
            match result {
                R::InputEmpty => finishing = true,
                R::OutputFull => self.bytes.resize(self.bytes.len() * 2, 0),
                R::OutputEndsFull => self.ends.resize(self.ends.len() * 2, 0),
                R::Record | R::End => break,
            }
        }
        self.count = count;
    }

    /// Field `i`, trimmed; empty past the end.
    fn field(&self, i: usize) -> &[u8] {
        if i >= self.count {
            return &[];
        }
        let start = if i == 0 { 0 } else { self.ends[i - 1] };
        self.bytes[start..self.ends[i]].trim_ascii()
    }
}

/// Where the record of physical line `number` (1-based) lies in `line`: without its line
/// break, and without a byte-order mark on line 1; `None` when it is blank or a `#`
/// comment.
fn record_range(line: &[u8], number: usize) -> Option<std::ops::Range<usize>> {
    let mut end = line.len();
    while end > 0 && matches!(line[end - 1], b'\n' | b'\r') {
        end -= 1;
    }
    let start = if number == 1 && line[..end].starts_with(b"\xef\xbb\xbf") {
        3
    } else {
        0
    };
    let trimmed = line[start..end].trim_ascii();
    (!trimmed.is_empty() && !trimmed.starts_with(b"#")).then_some(start..end)
}

/// Comma-separated records streamed from a reader, one physical line at a time: blank
/// lines and `#` comment lines skipped, fields split and unquoted by `csv-core`, then
/// trimmed. A record is one physical line, which keeps the line numbers exact (the `csv`
/// crate's own record positions count neither skipped blank lines nor comments). The line
/// and field buffers are reused: no allocation per row.
pub(crate) struct CsvLines<R> {
    input: R,
    line: Vec<u8>,
    fields: Fields,
    /// Physical line number of the current record (1-based).
    number: usize,
}

impl<R: std::io::BufRead> CsvLines<R> {
    pub(crate) fn new(input: R) -> Self {
        CsvLines {
            input,
            line: Vec::with_capacity(256),
            fields: Fields::new(),
            number: 0,
        }
    }

    /// The input, positioned after the current record's line, and that line's number.
    pub(crate) fn into_parts(self) -> (R, usize) {
        (self.input, self.number)
    }

    /// Advances to the next record; `Ok(false)` at the end of the input.
    pub(crate) fn advance(&mut self) -> std::io::Result<bool> {
        loop {
            self.line.clear();
            if self.input.read_until(b'\n', &mut self.line)? == 0 {
                return Ok(false);
            }
            self.number += 1;
            if let Some(record) = record_range(&self.line, self.number) {
                self.line.truncate(record.end);
                self.line.drain(..record.start);
                self.fields.split(&self.line);
                return Ok(true);
            }
        }
    }

    /// The current record's whole line (without its line break).
    pub(crate) fn raw(&self) -> &[u8] {
        &self.line
    }

    /// Physical line number (1-based) of the current record.
    pub(crate) fn line_number(&self) -> usize {
        self.number
    }

    /// Number of fields of the current record.
    pub(crate) fn len(&self) -> usize {
        self.fields.count
    }

    /// Field `i` of the current record, trimmed; empty past the end.
    pub(crate) fn field(&self, i: usize) -> &[u8] {
        self.fields.field(i)
    }

    /// Every field of the current record as text (UTF-8, else Latin-1).
    pub(crate) fn strings(&self) -> Vec<String> {
        (0..self.fields.count)
            .map(|i| decode_field(self.fields.field(i)))
            .collect()
    }
}

/// The records of whole lines already in memory, exactly as [`CsvLines`] reads them from
/// a stream (the same lines skipped, split and numbered), without copying each line.
pub(crate) struct SliceLines<'a> {
    rest: &'a [u8],
    fields: Fields,
    number: usize,
}

impl<'a> SliceLines<'a> {
    /// Records of `bytes` taken as a file's lines after line `number` (a piece of a file
    /// split at line breaks): line numbers go on from there.
    pub(crate) fn after_line(bytes: &'a [u8], number: usize) -> Self {
        SliceLines {
            rest: bytes,
            fields: Fields::new(),
            number,
        }
    }

    /// Advances to the next record; `false` at the end of the bytes.
    pub(crate) fn advance(&mut self) -> bool {
        while !self.rest.is_empty() {
            let end = memchr::memchr(b'\n', self.rest).map_or(self.rest.len(), |i| i + 1);
            let (line, rest) = self.rest.split_at(end);
            self.rest = rest;
            self.number += 1;
            if let Some(record) = record_range(line, self.number) {
                self.fields.split(&line[record]);
                return true;
            }
        }
        false
    }

    /// Physical line number (1-based) of the current record.
    pub(crate) fn line_number(&self) -> usize {
        self.number
    }

    /// Number of fields of the current record.
    pub(crate) fn len(&self) -> usize {
        self.fields.count
    }

    /// Field `i` of the current record, trimmed; empty past the end.
    pub(crate) fn field(&self, i: usize) -> &[u8] {
        self.fields.field(i)
    }
}

/// A field's bytes as text: UTF-8 when valid, else Latin-1.
pub(crate) fn decode_field(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(s) => s.to_owned(),
        Err(_) => decode_latin1(bytes),
    }
}

/// [`parse_cell`] on a field's bytes.
pub(crate) fn parse_field(
    path: &Path,
    line: usize,
    column: &str,
    bytes: &[u8],
) -> Result<f64, ReadError> {
    // `fast-float2` accepts exactly the strings the standard parser accepts, with the same
    // value (`the_byte_parser_agrees_with_the_standard_one`), and reads bytes: a field it
    // parses to a finite value needs no UTF-8 check and no second trim. Anything else
    // takes the standard path, which words the error.
    if let Ok(value) = fast_float2::parse::<f64, _>(bytes) {
        if value.is_finite() {
            return Ok(value);
        }
    }
    match std::str::from_utf8(bytes) {
        Ok(text) => parse_cell(path, line, column, text),
        Err(_) => parse_cell(path, line, column, &decode_latin1(bytes)),
    }
}

/// Segments built while streaming per-sample labels: each maximal run of equal labels is
/// one segment; unlabelled samples belong to none (as [`segments_from_labels`]).
#[derive(Default)]
pub(crate) struct SegmentRuns {
    segments: Vec<Segment>,
    /// First sample and raw label of the open run.
    current: Option<(usize, Vec<u8>)>,
    samples: usize,
}

impl SegmentRuns {
    /// The next sample's label (empty: none).
    pub(crate) fn push(&mut self, label: &[u8]) {
        let i = self.samples;
        self.samples += 1;
        if matches!(&self.current, Some((_, name)) if name == label) {
            return;
        }
        self.close(i);
        if !label.is_empty() {
            self.current = Some((i, label.to_vec()));
        }
    }

    fn close(&mut self, end: usize) {
        if let Some((start, name)) = self.current.take() {
            self.segments.push(Segment {
                name: decode_field(&name),
                start,
                end,
            });
        }
    }

    /// The segments.
    pub(crate) fn finish(mut self) -> Vec<Segment> {
        self.close(self.samples);
        self.segments
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streamed_records_keep_physical_line_numbers_quotes_and_long_rows() {
        let long: Vec<String> = (0..40).map(|i| format!("{i}.{}", "0".repeat(20))).collect();
        let text = format!(
            "\u{feff}# comment\r\n\r\ntime_s,\"a,b\" ,\"say \"\"hi\"\"\"\r\n  \n1,2,3\n# c\n{}\n\"open",
            long.join(",")
        );
        let mut rows = CsvLines::new(text.as_bytes());
        let mut seen = Vec::new();
        while rows.advance().unwrap() {
            seen.push((rows.line_number(), rows.strings()));
        }
        assert_eq!(seen.len(), 4);
        assert_eq!(seen[0].0, 3);
        assert_eq!(seen[0].1, ["time_s", "a,b", "say \"hi\""]);
        assert_eq!(seen[1], (5, vec!["1".into(), "2".into(), "3".into()]));
        assert_eq!(seen[2].0, 7);
        assert_eq!(seen[2].1, long);
        assert_eq!(seen[3], (8, vec!["open".to_owned()]));
    }

    /// The fast path of [`parse_field`] must not accept what the standard parser refuses,
    /// nor read another value.
    #[test]
    fn the_byte_parser_agrees_with_the_standard_one() {
        let mut cases: Vec<String> = [
            "inf",
            "-inf",
            "+inf",
            "infinity",
            "Infinity",
            "INF",
            "infinit",
            "infinityy",
            "nan",
            "NaN",
            "-nan",
            "+nan",
            "nan(1)",
            "nan1",
            "1.",
            "-1.",
            ".5",
            "+.5",
            "-.5",
            ".",
            "+",
            "-",
            "",
            "e5",
            "1e",
            "1e+",
            "1e-",
            "1e5",
            "1E5",
            "1e+5",
            "1.e5",
            ".e5",
            "+e5",
            "1e5.0",
            "+1",
            "++1",
            "+-1",
            "--1",
            "1..2",
            "1.2.3",
            "0x10",
            "1_0",
            " 1",
            "1 ",
            "1d5",
            "1f",
            "1,5",
            "0",
            "-0",
            "00012",
            "1e400",
            "-1e400",
            "1e-400",
            "4.9e-324",
            "2.2250738585072014e-308",
            "1.7976931348623157e308",
            "1.7976931348623159e308",
            "9007199254740993",
            "1e0000000000000000000001",
            "١",
            "１",
            "∞",
            "1\u{a0}",
        ]
        .iter()
        .map(|s| (*s).to_owned())
        .collect();
        // Numbers as loggers print them, and every spelling of a few awkward values.
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let v = f64::from_bits(x);
            if v.is_finite() {
                cases.extend([format!("{v}"), format!("{v:e}"), format!("{v:.6e}")]);
                cases.push(format!("{:.4}", (x % 2_000_000) as f64 * 1e-3 - 1e3));
            }
        }
        for case in &cases {
            let standard = case.parse::<f64>().ok();
            let fast = fast_float2::parse::<f64, _>(case.as_bytes()).ok();
            match (standard, fast) {
                (Some(a), Some(b)) => assert!(
                    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                    "{case:?}: {a} vs {b}"
                ),
                (None, Some(b)) => panic!("{case:?}: refused by std, read as {b}"),
                _ => {}
            }
            let field = parse_field(Path::new("f.csv"), 1, "x", case.trim().as_bytes());
            let cell = parse_cell(Path::new("f.csv"), 1, "x", case);
            assert_eq!(
                field
                    .as_ref()
                    .map(|v| v.to_bits())
                    .map_err(ToString::to_string),
                cell.as_ref()
                    .map(|v| v.to_bits())
                    .map_err(ToString::to_string),
                "{case:?}"
            );
        }
    }

    #[test]
    fn segment_runs_match_segments_from_labels() {
        let labels = ["a", "a", "", "b", "b", "a", "\u{e9}"];
        let mut runs = SegmentRuns::default();
        for l in labels {
            runs.push(l.as_bytes());
        }
        let owned: Vec<Option<String>> = labels
            .iter()
            .map(|l| (!l.is_empty()).then(|| (*l).to_owned()))
            .collect();
        assert_eq!(runs.finish(), segments_from_labels(&owned));
    }
}
