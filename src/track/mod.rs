//! track (work in progress).
