//! Runs of foreground in bitmap rows, found 8 bytes at a time.
//!
//! Masks and detector bitmaps are rows of bytes, non-zero = foreground, and most of what
//! reads them (the connected-component labeller, a mask's moments, its box, its hull, its
//! RLE) wants a row's runs, not its pixels. Byte by byte these scans were a seventh of the
//! background subtractor's time at 1920×1080 in wasm, and the per-pixel loops of a mask's
//! moments and hull a few percent of the tracker's there (issue 10): a word test over 8 bytes
//! skips background and foreground alike. Written here because no crate scans byte rows this
//! way without `unsafe` or a SIMD dependency (`memchr` finds one byte value, not "non-zero").

const ONES: u64 = 0x0101_0101_0101_0101;
const HIGHS: u64 = 0x8080_8080_8080_8080;

/// One little-endian word of 8 bytes.
fn word(chunk: &[u8]) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(chunk);
    u64::from_le_bytes(a)
}

/// Index of the first byte of `row` that `byte` accepts, 8 bytes at a time: `word_test`
/// marks, in a little-endian word of 8 bytes, at least the first accepted byte with a set bit
/// inside it and no bit in the bytes before it.
fn first_where(
    row: &[u8],
    word_test: impl Fn(u64) -> u64,
    byte: impl Fn(u8) -> bool,
) -> Option<usize> {
    let mut words = row.chunks_exact(8);
    for (k, chunk) in words.by_ref().enumerate() {
        let hits = word_test(word(chunk));
        if hits != 0 {
            return Some(8 * k + (hits.trailing_zeros() / 8) as usize);
        }
    }
    let done = row.len() - words.remainder().len();
    words
        .remainder()
        .iter()
        .position(|&v| byte(v))
        .map(|p| done + p)
}

/// Index of the first non-zero byte.
pub(crate) fn first_nonzero(row: &[u8]) -> Option<usize> {
    first_where(row, |x| x, |v| v != 0)
}

/// Index of the first zero byte (`row.len()` when none).
pub(crate) fn first_zero(row: &[u8]) -> usize {
    // The high bit of each zero byte is set, and possibly those of bytes above the first zero
    // one (a borrow): the lowest is exact.
    first_where(row, |x| x.wrapping_sub(ONES) & !x & HIGHS, |v| v == 0).unwrap_or(row.len())
}

/// Index of the last non-zero byte.
pub(crate) fn last_nonzero(row: &[u8]) -> Option<usize> {
    let mut words = row.rchunks_exact(8);
    for (k, chunk) in words.by_ref().enumerate() {
        let x = word(chunk);
        if x != 0 {
            // The highest set bit's byte is the last non-zero one of this word.
            let byte = 7 - (x.leading_zeros() / 8) as usize;
            return Some(row.len() - 8 * (k + 1) + byte);
        }
    }
    words.remainder().iter().rposition(|&v| v != 0)
}

/// The runs of non-zero bytes of `row`, left to right, as `(start, end)` (end exclusive).
pub(crate) fn runs(row: &[u8]) -> impl Iterator<Item = (usize, usize)> + '_ {
    let mut x = 0;
    std::iter::from_fn(move || {
        let start = x + first_nonzero(row.get(x..)?)?;
        let end = start + first_zero(&row[start..]);
        x = end;
        Some((start, end))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows of long runs of one kind, foreground written as 1 or as any other byte.
    fn rows() -> Vec<Vec<u8>> {
        let mut s = 99u32;
        let mut out = Vec::new();
        for len in 0..70 {
            for _ in 0..40 {
                let mut row = Vec::with_capacity(len + 20);
                while row.len() < len {
                    s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
                    let v = match (s >> 16) % 8 {
                        0..=3 => 0,
                        4..=5 => 1,
                        6 => 0x80,
                        _ => 0xff,
                    };
                    let n = 1 + (s >> 8) as usize % 20;
                    row.extend(std::iter::repeat_n(v, n));
                }
                row.truncate(len);
                out.push(row);
            }
        }
        out
    }

    #[test]
    fn the_word_scans_find_what_a_byte_scan_finds() {
        for row in rows() {
            for from in 0..=row.len() {
                let r = &row[from..];
                assert_eq!(first_nonzero(r), r.iter().position(|&v| v != 0));
                assert_eq!(
                    first_zero(r),
                    r.iter().position(|&v| v == 0).unwrap_or(r.len())
                );
                assert_eq!(last_nonzero(r), r.iter().rposition(|&v| v != 0));
                let r = &row[..from];
                assert_eq!(last_nonzero(r), r.iter().rposition(|&v| v != 0));
            }
        }
    }

    #[test]
    fn runs_are_the_rows_foreground_runs() {
        for row in rows() {
            let mut want = Vec::new();
            let mut x = 0;
            while x < row.len() {
                if row[x] == 0 {
                    x += 1;
                    continue;
                }
                let start = x;
                while x < row.len() && row[x] != 0 {
                    x += 1;
                }
                want.push((start, x));
            }
            assert_eq!(runs(&row).collect::<Vec<_>>(), want, "{row:?}");
        }
    }
}
