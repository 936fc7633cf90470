//! The measured record: force and probe position against time, in SI, as read from a
//! file and before any processing (no offset removal, no contact detection, no filtering).
//!
//! Conventions, shared by every reader so that downstream code never has to ask where a
//! record came from:
//! - `position_m` is the probe (tip) position, positive INTO the material;
//! - `force_n` is the contact force, positive in compression (the material pushes back);
//!   raw: a sensor offset stays in the data.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use crate::readers::{ReadError, ReadErrorKind};

/// A force/position record in SI, as read from a file, before any processing.
///
/// Invariants established by the readers: the three series have the same length (≥ 2),
/// every value is finite and `time_s` is strictly increasing.
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// Sample times \[s\], strictly increasing.
    pub time_s: Vec<f64>,
    /// Probe (tip) position \[m\], positive into the material.
    pub position_m: Vec<f64>,
    /// Contact force \[N\], positive in compression; raw (sensor offset not removed).
    pub force_n: Vec<f64>,
    /// The file the record was read from.
    pub source: PathBuf,
    /// The file format it was read as.
    pub format: Format,
    /// Named index ranges if the file has them (AFM extend/pause/retract, ...); may be
    /// empty.
    pub segments: Vec<Segment>,
    /// The conversions applied, in words (one per entry).
    pub notes: Vec<String>,
}

/// A named, half-open range of sample indices `start..end` of a [`Record`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Segment {
    /// The segment's name (e.g. `"extend"`, `"hold"`).
    pub name: String,
    /// First sample index.
    pub start: usize,
    /// One past the last sample index (exclusive).
    pub end: usize,
}

impl Segment {
    /// The index range `start..end`.
    pub fn range(&self) -> std::ops::Range<usize> {
        self.start..self.end
    }

    /// Number of samples in the segment.
    pub fn len(&self) -> usize {
        self.end.saturating_sub(self.start)
    }

    /// True when the segment holds no sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The file formats the readers understand; `Display`/`FromStr` use the CLI names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// The project's own log: CSV with header `time_s,position_m,force_n`, SI.
    Csv,
    /// JPK "TEXT EXPORT" of an AFM force curve (segments extend/pause/retract).
    Jpk,
    /// afmformats tab-separated export (JSON metadata, `segment` column).
    AfmTab,
    /// Hysitron nanoindentation text export (Latin-1, `Depth (nm)`, `Load (µN)`).
    Hysitron,
    /// Instron compression CSV (`Time (s),Compression (mm),Load (N),...`).
    Instron,
}

impl Format {
    /// Every format, in the order auto-detection tries them.
    pub const ALL: [Format; 5] = [
        Format::Jpk,
        Format::AfmTab,
        Format::Hysitron,
        Format::Instron,
        Format::Csv,
    ];

    /// The CLI name: `csv`, `jpk`, `afm-tab`, `hysitron` or `instron`.
    pub fn name(self) -> &'static str {
        match self {
            Format::Csv => "csv",
            Format::Jpk => "jpk",
            Format::AfmTab => "afm-tab",
            Format::Hysitron => "hysitron",
            Format::Instron => "instron",
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A format name that is none of the CLI names.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown format `{0}`; expected one of csv, jpk, afm-tab, hysitron, instron")]
pub struct UnknownFormatName(pub String);

impl FromStr for Format {
    type Err = UnknownFormatName;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Format::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| UnknownFormatName(s.to_owned()))
    }
}

/// Why [`Record::try_resample`] refused a rate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResampleError {
    /// The rate is NaN, infinite, zero or negative.
    #[error("field `rate_hz`: must be finite and > 0, got {0}")]
    InvalidRate(f64),
    /// The record has fewer than two samples or a time span that is not finite and > 0.
    #[error("field `time_s`: need at least 2 samples spanning a finite, positive time")]
    DegenerateTime,
    /// The new grid would exceed [`Record::MAX_RESAMPLED_LEN`] samples.
    #[error("field `rate_hz`: {rate_hz} Hz over {span_s} s gives more than {max} samples")]
    TooManySamples {
        /// The requested rate \[Hz\].
        rate_hz: f64,
        /// The record's time span \[s\].
        span_s: f64,
        /// The cap.
        max: usize,
    },
    /// The grid would hold more than [`Record::MAX_UPSAMPLING`] points per source sample:
    /// the record is too sparse for the rate, and interpolation would invent the signal.
    #[error(
        "field `time_s`: {samples} samples over {span_s} s are too sparse to resample at {rate_hz} Hz ({points} grid points, more than {max_ratio} per sample)"
    )]
    TooSparse {
        /// The requested rate \[Hz\].
        rate_hz: f64,
        /// The record's time span \[s\].
        span_s: f64,
        /// Source samples.
        samples: usize,
        /// Grid points the rate would give.
        points: usize,
        /// The cap on grid points per source sample.
        max_ratio: usize,
    },
}

impl Record {
    /// Largest grid [`Record::try_resample`] builds (guards against a mistyped rate
    /// exhausting memory).
    pub const MAX_RESAMPLED_LEN: usize = 20_000_000;

    /// Largest number of grid points per source sample [`Record::try_resample`] accepts.
    /// The slowest real format (AFM segments at 256 Hz) is 4 points per sample at 1 kHz;
    /// a few samples spread over hours are not a signal to interpolate.
    pub const MAX_UPSAMPLING: usize = 100;

    /// Relative tolerance on sampling intervals for [`Record::sample_rate_hz`].
    pub const UNIFORM_TOLERANCE: f64 = 1e-3;

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// True when the record holds no sample.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// The first segment called `name`, if any.
    pub fn segment(&self, name: &str) -> Option<&Segment> {
        self.segments.iter().find(|s| s.name == name)
    }

    /// The sampling rate \[Hz\] when the record is uniformly sampled: every interval within
    /// a relative [`Record::UNIFORM_TOLERANCE`] (1e-3) of the mean interval. `None` when
    /// any interval deviates (one late sample is enough), or with fewer than 2 samples.
    pub fn sample_rate_hz(&self) -> Option<f64> {
        let (first, last) = (self.time_s.first()?, self.time_s.last()?);
        let intervals = self.time_s.len().checked_sub(1).filter(|&n| n > 0)?;
        let mean_dt = (last - first) / intervals as f64;
        if !(mean_dt.is_finite() && mean_dt > 0.0) {
            return None;
        }
        let uniform = self
            .time_s
            .windows(2)
            .all(|w| ((w[1] - w[0]) - mean_dt).abs() <= Self::UNIFORM_TOLERANCE * mean_dt);
        uniform.then_some(1.0 / mean_dt)
    }

    /// The record on a uniform grid `t_k = time_s\[0\] + k / rate_hz`, `k = 0..` up to the
    /// last sample. See [`Record::try_resample`]; on a refused rate this returns an
    /// unchanged copy whose last note says why.
    pub fn resample(&self, rate_hz: f64) -> Record {
        self.try_resample(rate_hz).unwrap_or_else(|e| {
            let mut copy = self.clone();
            copy.notes.push(format!("resample not done: {e}"));
            copy
        })
    }

    /// The record on a uniform grid `t_k = time_s\[0\] + k / rate_hz`, `k = 0..=K` with
    /// `t_K ≤ time_s\[last\]`.
    ///
    /// Each grid point owns the target interval `[t_k − h/2, t_k + h/2)`, `h = 1/rate_hz`.
    /// Where the two source samples around `t_k` are less than `h` apart (source denser
    /// than the target) the point is the mean over that interval of the source held over
    /// each sample's cell (midway to its neighbours): each sample weighed by its cell's
    /// overlap with the interval (a boxcar anti-alias whose weights move continuously with
    /// the time stamps: ¼, ½, ¼ for a 2 kHz file at 1 kHz); otherwise it is the linear
    /// interpolation of the two source samples around `t_k`. The choice is made per grid
    /// point, so nonuniform records (AFM segments at 256 and 2048 Hz) are handled piece
    /// by piece. A segment `start..end` maps to the grid points whose time lies in
    /// `[time_s\[start\], time_s\[end\])` (to the end of the grid for the last one).
    ///
    /// # Errors
    /// [`ResampleError`] when `rate_hz` is not finite and positive, the record spans no
    /// time, the grid would exceed [`Record::MAX_RESAMPLED_LEN`] samples, or hold more
    /// than [`Record::MAX_UPSAMPLING`] points per source sample.
    pub fn try_resample(&self, rate_hz: f64) -> Result<Record, ResampleError> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(ResampleError::InvalidRate(rate_hz));
        }
        let n_src = self
            .time_s
            .len()
            .min(self.position_m.len())
            .min(self.force_n.len());
        let (t0, t_last) = match (self.time_s.first(), self.time_s.get(n_src.wrapping_sub(1))) {
            (Some(&a), Some(&b)) if n_src >= 2 => (a, b),
            _ => return Err(ResampleError::DegenerateTime),
        };
        let span_s = t_last - t0;
        if !(span_s.is_finite() && span_s > 0.0) {
            return Err(ResampleError::DegenerateTime);
        }
        // The small relative slack keeps the last source sample when span * rate is an
        // integer up to rounding (32.0 s at 1 kHz must give 32001 points, not 32000).
        let last_k = (span_s * rate_hz * (1.0 + 1e-12)).floor();
        if !(last_k.is_finite() && last_k < Self::MAX_RESAMPLED_LEN as f64) {
            return Err(ResampleError::TooManySamples {
                rate_hz,
                span_s,
                max: Self::MAX_RESAMPLED_LEN,
            });
        }
        let n_new = last_k as usize + 1;
        if n_new > Self::MAX_UPSAMPLING * n_src {
            return Err(ResampleError::TooSparse {
                rate_hz,
                span_s,
                samples: n_src,
                points: n_new,
                max_ratio: Self::MAX_UPSAMPLING,
            });
        }
        let h = 1.0 / rate_hz;
        let src_t = &self.time_s[..n_src];
        let src_x = &self.position_m[..n_src];
        let src_f = &self.force_n[..n_src];

        let mut time_s = Vec::with_capacity(n_new);
        let mut position_m = Vec::with_capacity(n_new);
        let mut force_n = Vec::with_capacity(n_new);
        let mut averaged = 0usize;
        // On the grid's own axis u = (t − t0)·rate each source sample holds its value over
        // its own cell, from midway to the sample before to midway to the one after (the
        // end samples' cells as wide on the outer side as on the inner). A grid point
        // where the source is denser than the grid (the two samples around it less than
        // a grid step apart) is the mean of that held signal over its interval
        // [k − ½, k + ½): each sample weighed by its cell's overlap with it. The weights
        // move continuously with the time stamps: a 2 kHz file's samples on the interval's
        // edges weigh ¼ in each of the two (¼, ½, ¼), where a plain mean of the samples
        // inside took one, two or three of them as each stamp rounded or jittered, and
        // the means' times jittered by a quarter of a millisecond (a 6.5 Hz tap's depth by
        // ≈ 6 µm, its acceleration by tens of m/s² where it is 1: a mass on such a record
        // was fitted 29-70 % low). At a spacing of one step the overlap weights are the
        // linear interpolation's, so the two rules meet where the source stops being
        // denser.
        let u: Vec<f64> = src_t.iter().map(|t| (t - t0) * rate_hz).collect();
        // `lo`: `cell_overlaps`'s cursor; `j` = interpolation bracket.
        let mut lo = 0usize;
        let mut j = 0usize;
        for k in 0..n_new {
            let t = t0 + k as f64 * h;
            while j + 2 < n_src && src_t[j + 1] <= t {
                j += 1;
            }
            let (ta, tb) = (src_t[j], src_t[j + 1]);
            let (x, f) = if (tb - ta) * rate_hz < 1.0 {
                averaged += 1;
                let (mut w_sum, mut x_sum, mut f_sum) = (0.0, 0.0, 0.0);
                cell_overlaps(&u, k as f64, &mut lo, |i, w| {
                    w_sum += w;
                    x_sum += w * src_x[i];
                    f_sum += w * src_f[i];
                });
                (x_sum / w_sum, f_sum / w_sum)
            } else {
                let w = if tb > ta {
                    ((t - ta) / (tb - ta)).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (
                    src_x[j] + w * (src_x[j + 1] - src_x[j]),
                    src_f[j] + w * (src_f[j + 1] - src_f[j]),
                )
            };
            time_s.push(t);
            position_m.push(x);
            force_n.push(f);
        }

        // Grid index of the first grid time ≥ source time `t`.
        let grid_index = |t: f64| -> usize {
            let k = ((t - t0) * rate_hz * (1.0 - 1e-12)).ceil();
            if k <= 0.0 {
                0
            } else if k >= n_new as f64 {
                n_new
            } else {
                k as usize
            }
        };
        let map = |i: usize| -> usize {
            match src_t.get(i) {
                Some(&t) => grid_index(t),
                None => n_new,
            }
        };
        let segments = self
            .segments
            .iter()
            .map(|s| Segment {
                name: s.name.clone(),
                start: map(s.start),
                end: map(s.end).max(map(s.start)),
            })
            .collect();

        let mut notes = self.notes.clone();
        notes.push(format!(
            "resampled to {rate_hz} Hz on a uniform grid from t = {t0} s ({n_src} -> {n_new} \
             samples): {averaged} grid points are the source's mean over ±half a target \
             interval, each sample weighed by the overlap of its own cell (anti-alias, \
             source denser), the others are linear interpolations"
        ));
        Ok(Record {
            time_s,
            position_m,
            force_n,
            source: self.source.clone(),
            format: self.format,
            segments,
            notes,
        })
    }

    /// Writes the record in the project's own format: CSV with header
    /// `time_s,position_m,force_n` (SI), plus a `segment` column holding each sample's
    /// segment name when the record has segments (the `csv` reader restores them).
    /// Values are written with Rust's shortest round-trip formatting, so a read back
    /// gives the same numbers bit for bit.
    ///
    /// # Errors
    /// [`ReadError`] with [`ReadErrorKind::Io`] when the file cannot be created or written.
    pub fn write_csv(&self, path: &Path) -> Result<(), ReadError> {
        let io_err = |e: std::io::Error| ReadError::file(path, ReadErrorKind::Io(e));
        let file = std::fs::File::create(path).map_err(io_err)?;
        let mut w = csv::Writer::from_writer(std::io::BufWriter::new(file));
        let with_segments = !self.segments.is_empty();
        let mut labels: Vec<&str> = Vec::new();
        if with_segments {
            labels = vec![""; self.len()];
            // Earlier segments win where segments overlap.
            for s in self.segments.iter().rev() {
                for label in labels.iter_mut().take(s.end).skip(s.start) {
                    *label = &s.name;
                }
            }
        }
        let header: &[&str] = if with_segments {
            &["time_s", "position_m", "force_n", "segment"]
        } else {
            &["time_s", "position_m", "force_n"]
        };
        w.write_record(header).map_err(|e| io_err(e.into()))?;
        let rows = self
            .time_s
            .iter()
            .zip(&self.position_m)
            .zip(&self.force_n)
            .enumerate();
        for (i, ((t, x), f)) in rows {
            let (t, x, f) = (t.to_string(), x.to_string(), f.to_string());
            let result = match labels.get(i) {
                Some(label) if with_segments => {
                    w.write_record([t.as_str(), x.as_str(), f.as_str(), label])
                }
                _ => w.write_record([&t, &x, &f]),
            };
            result.map_err(|e| io_err(e.into()))?;
        }
        w.flush().map_err(io_err)
    }
}

/// The overlap of each source sample's cell with the interval `[centre − ½, centre + ½)`,
/// on an axis whose unit is one target interval ([`Record::try_resample`]'s grid:
/// u = (t − t₀)·rate): `each(i, w)` for every sample i whose cell overlaps it, w its
/// length of overlap (≤ 1). `u`: the source samples' positions on that axis, increasing,
/// at least 2. A sample's cell runs from midway to the sample before to midway to the
/// one after; the end samples' cells are as wide on the outer side as on the inner.
/// `cursor`: the first sample to consider, advanced past the cells that end before the
/// interval (0 to start; calls with increasing centres reuse it).
///
/// One definition for the resampler's averaged points and for the diagnosis, which
/// models a resampled file's force at a contact's edge as the same weighted mean of the
/// law at the file's own samples (`diagnose::regressors::design`).
pub fn cell_overlaps(u: &[f64], centre: f64, cursor: &mut usize, mut each: impl FnMut(usize, f64)) {
    let n = u.len();
    if n < 2 {
        return;
    }
    let cell_lo = |i: usize| {
        if i == 0 {
            u[0] - 0.5 * (u[1] - u[0])
        } else {
            0.5 * (u[i - 1] + u[i])
        }
    };
    let cell_hi = |i: usize| {
        if i + 1 == n {
            u[i] + 0.5 * (u[i] - u[i - 1])
        } else {
            0.5 * (u[i] + u[i + 1])
        }
    };
    let (from, to) = (centre - 0.5, centre + 0.5);
    while *cursor > 0 && cell_hi(*cursor - 1) > from {
        *cursor -= 1;
    }
    while *cursor + 1 < n && cell_hi(*cursor) <= from {
        *cursor += 1;
    }
    let mut i = *cursor;
    while i < n && cell_lo(i) < to {
        let w = cell_hi(i).min(to) - cell_lo(i).max(from);
        if w > 0.0 {
            each(i, w);
        }
        i += 1;
    }
}
