//! File readers (placeholder until the readers land).
