//! detect (work in progress).
