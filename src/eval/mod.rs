//! eval (work in progress).

pub mod vot;
