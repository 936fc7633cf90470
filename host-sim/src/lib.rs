//! Host tools (work in progress).
