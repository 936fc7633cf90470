//! The error every reader returns: where in the file (path, 1-based physical line, field)
//! and what is wrong with it.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::record::Format;

/// A file that could not be read into a [`Record`](crate::record::Record).
///
/// Displays as `{path}:{line}: field ` + the field name in backticks + `: {message}`,
/// the line and the field only when known; lines are 1-based physical line numbers of
/// the file. For example:
///
/// ```text
/// data/log.csv:3: field `force_n`: not a number: "abc"
/// ```
#[derive(Debug, thiserror::Error)]
#[error("{}: {kind}", Location(self))]
pub struct ReadError {
    /// The file being read (or written).
    pub path: PathBuf,
    /// 1-based physical line number, when the error belongs to one line.
    pub line: Option<usize>,
    /// The column or header field at fault, when there is one.
    pub field: Option<String>,
    /// What is wrong.
    pub kind: ReadErrorKind,
}

/// What is wrong with a file; the message part of a [`ReadError`].
#[derive(Debug, thiserror::Error)]
pub enum ReadErrorKind {
    /// The operating system refused to read or write the file.
    #[error("I/O error: {0}")]
    Io(std::io::Error),
    /// The file has no bytes at all (or only whitespace).
    #[error("the file is empty")]
    Empty,
    /// A header was found but no data row follows it.
    #[error("no data rows")]
    NoData,
    /// A required column (or header field) is absent.
    #[error("missing column; expected {}; found {}", join(.expected), join_or_none(.found))]
    MissingColumn {
        /// All the columns the reader needs, in its order.
        expected: Vec<String>,
        /// The columns the file has.
        found: Vec<String>,
    },
    /// A row has a different number of cells than its header.
    #[error("row has {found} cells, the header on line {header_line} has {expected}")]
    RowLength {
        /// Cells in the header.
        expected: usize,
        /// Cells in this row.
        found: usize,
        /// Line of the header the row is checked against.
        header_line: usize,
    },
    /// A cell that must hold a number does not parse as one.
    #[error("not a number: {text:?}")]
    NonNumeric {
        /// The cell's text, trimmed.
        text: String,
    },
    /// A cell (or a value derived from cells) is NaN or infinite.
    #[error("not finite: {text:?}")]
    NonFinite {
        /// The cell's text, or the derived value.
        text: String,
    },
    /// A value that the estimator core, which computes in f32, cannot take: beyond
    /// ±f32::MAX it overflows, beyond the pipeline's input range (±1e6 m or N) it would
    /// be dropped as a sensor fault.
    #[error("{value:e} {unit} {reason}")]
    OutOfRange {
        /// The value in SI.
        value: f64,
        /// Its unit.
        unit: &'static str,
        /// "overflows f32 (|x| ≤ 3.4e38)" or the pipeline's limit.
        reason: &'static str,
    },
    /// Time does not strictly increase from one row to the next.
    #[error("time not strictly increasing: {value} s here, {previous} s on line {previous_line}")]
    TimeNotIncreasing {
        /// Time on this line.
        value: f64,
        /// Time on the previous data line.
        previous: f64,
        /// The previous data line.
        previous_line: usize,
    },
    /// Fewer than two samples: nothing to process.
    #[error("only {found} data row(s); at least 2 are needed")]
    TooFewSamples {
        /// Data rows found.
        found: usize,
    },
    /// The file header declares a number of points that the data does not have.
    #[error("the header declares {declared} points but {found} data rows were found{}", self.rows_span())]
    PointCount {
        /// Points declared in the header.
        declared: usize,
        /// Data rows found.
        found: usize,
        /// Line of the first data row, if any.
        first_line: Option<usize>,
        /// Line of the last data row, if any.
        last_line: Option<usize>,
    },
    /// Header or metadata content that the reader cannot use.
    #[error("{0}")]
    Invalid(String),
    /// No reader recognised the content.
    #[error("unknown format; tried {}", describe_tried(.tried))]
    UnknownFormat {
        /// The formats tried, in order.
        tried: Vec<Format>,
    },
}

impl ReadError {
    /// An error about the whole file (no line, no field).
    pub fn file(path: &Path, kind: ReadErrorKind) -> Self {
        ReadError {
            path: path.to_path_buf(),
            line: None,
            field: None,
            kind,
        }
    }

    /// An error about one line, optionally one field of it.
    pub fn at(path: &Path, line: usize, field: Option<&str>, kind: ReadErrorKind) -> Self {
        ReadError {
            path: path.to_path_buf(),
            line: Some(line),
            field: field.map(str::to_owned),
            kind,
        }
    }
}

struct Location<'a>(&'a ReadError);

impl fmt::Display for Location<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0.path.display())?;
        if let Some(line) = self.0.line {
            write!(f, ":{line}")?;
        }
        if let Some(field) = &self.0.field {
            write!(f, ": field `{field}`")?;
        }
        Ok(())
    }
}

impl ReadErrorKind {
    fn rows_span(&self) -> String {
        match self {
            ReadErrorKind::PointCount {
                first_line: Some(first),
                last_line: Some(last),
                ..
            } => format!(" (lines {first}-{last})"),
            _ => String::new(),
        }
    }
}

fn join(names: &[String]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn join_or_none(names: &[String]) -> String {
    if names.is_empty() {
        "none".to_owned()
    } else {
        join(names)
    }
}

fn describe_tried(tried: &[Format]) -> String {
    tried
        .iter()
        .map(|f| format!("{f} ({})", super::signature(*f)))
        .collect::<Vec<_>>()
        .join(", ")
}
