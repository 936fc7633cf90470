//! Host tools around the estimator core: the measured-record type and file readers, a
//! simulated 1 kHz plant, the paper's experiments as scenarios, the per-sample pipeline
//! run over records, plots, and the discrepancy workflow. The `host-sim` binary is the
//! command-line front end.

pub mod batch;
pub mod diagnose;
pub mod files;
pub mod frontend;
pub mod generator;
pub mod phases;
pub mod plant;
pub mod plots;
pub mod readers;
pub mod record;
pub mod recordings;
pub mod report;
pub mod runner;
pub mod scenarios;
pub mod serial;
pub mod setup;
pub mod simulate;
pub mod telemetry;
