//! Per-shape features and pairwise costs: SIFT keypoints (a port of OpenCV's), shape context
//! (thesis ch. 4.3), the spatial colour analyser (ch. 4.4), and the 2-D transforms both use to
//! align one shape onto another.
pub mod color;
pub mod shape_context;
pub mod sift;
pub mod transform;
