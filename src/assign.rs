//! assign (work in progress).
