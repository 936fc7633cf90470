//! The measured record (placeholder until the readers land).
