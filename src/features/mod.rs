//! features (work in progress).
