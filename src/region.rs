//! region (work in progress).
