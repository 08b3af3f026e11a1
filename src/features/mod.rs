//! features (work in progress).

pub mod sift;
