//! FNV-1a, 64 bits, and the committed digest files: for the tests that compare a run with a
//! digest the native build wrote (and the wasm build must equal). A digest of its own rather
//! than a `Hash` impl, whose output may change between targets and releases; apart from
//! `tests/common/mod.rs` (proptest does not build for wasm32), so the wasm suites can use it.
#![allow(dead_code)]

/// The FNV-1a offset basis: a fresh digest's state.
pub const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// An FNV-1a digest; `.0` is its value.
pub struct Fnv(pub u64);

impl Fnv {
    /// Takes in `b`, byte by byte.
    pub fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= u64::from(x);
            self.0 = self.0.wrapping_mul(0x100_0000_01b3);
        }
    }

    /// Takes in `x`'s little-endian bytes.
    pub fn u64(&mut self, x: u64) {
        self.bytes(&x.to_le_bytes());
    }

    /// Takes in `x`'s bits.
    pub fn f64(&mut self, x: f64) {
        self.u64(x.to_bits());
    }
}

/// The digest lines of a committed file: trimmed, without `#` comments and blank lines.
pub fn committed_lines(text: &str) -> Vec<String> {
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| l.trim().to_string())
        .collect()
}
