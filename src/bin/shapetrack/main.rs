//! The `shapetrack` command-line tool.
fn main() {}
