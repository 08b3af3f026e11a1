//! motion (work in progress).
