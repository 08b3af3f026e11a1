//! Where the columns of a 0/1 bitmap change value down their rows, found a word of 8 pixels
//! at a time: what `Rle::from_mask` builds its runs from, in buffers each thread reuses.

use crate::scratch::Scratch;

/// Where each column of a part of a 0/1 bitmap changes value down its rows: the rows (from
/// 0, the part's first) whose pixel differs from the one above, the row above the first
/// being background ([`Rle::from_mask`]). Its buffers are reused from one mask to the next
/// ([`with_scratch`]).
#[derive(Debug)]
pub(super) struct ColumnChanges {
    /// Per column, where its changes start in `rows` (one more entry than columns).
    starts: Vec<usize>,
    /// The changes' rows, column after column, top down within each.
    rows: Vec<usize>,
    /// The changes as (column, row) in row order, before they are grouped by column.
    pub(super) found: Vec<(usize, usize)>,
    /// Per column, the next free place in `rows` while grouping.
    fill: Vec<usize>,
    /// Zeros (never written): the row above the first, and any row outside the bitmap.
    zeros: Vec<u8>,
}

thread_local! {
    /// One [`ColumnChanges`] per thread, reused by every mask encoded: each mask allocated
    /// its five buffers, and the page encodes every shape of every frame (issue 10: in the
    /// browser build's profile, a seventh of the allocator's time was this function's).
    pub(super) static CHANGES: std::cell::RefCell<ColumnChanges> =
        const { std::cell::RefCell::new(ColumnChanges::EMPTY) };
}

/// Most changes whose buffers [`CHANGES`] keeps between masks (1 MiB of them): a solid
/// shape has about two per column.
pub(super) const KEPT_CHANGES: usize = 1 << 16;

impl Scratch for ColumnChanges {
    const EMPTY: Self = Self {
        starts: Vec::new(),
        rows: Vec::new(),
        found: Vec::new(),
        fill: Vec::new(),
        zeros: Vec::new(),
    };

    /// A ragged mask can have a change at most pixels: its buffers are not kept for the
    /// ordinary masks after it.
    fn oversized(&self) -> bool {
        self.found.capacity() > KEPT_CHANGES
    }
}

impl ColumnChanges {
    /// Fills in the changes of columns `c0..c1` over rows `row0..row0 + rows` of a
    /// `stride`-wide bitmap.
    pub(super) fn find(
        &mut self,
        bits: &[u8],
        stride: usize,
        (row0, rows): (usize, usize),
        (c0, c1): (usize, usize),
    ) {
        let cols = c1.saturating_sub(c0);
        if self.zeros.len() < cols {
            self.zeros.resize(cols, 0);
        }
        let zeros = &self.zeros[..cols];
        let row = |r: usize| -> &[u8] {
            let start = (row0 + r) * stride + c0;
            bits.get(start..start + cols).unwrap_or(zeros)
        };
        // The changes as (column, row), row by row: the rows are scanned once, and the
        // changes (about two a column for a solid shape, against a word per 8 pixels
        // scanned) are then grouped by column with a counting sort.
        let found = &mut self.found;
        found.clear();
        for r in 0..rows {
            let (above, here) = (if r == 0 { zeros } else { row(r - 1) }, row(r));
            let (mut a, mut b) = (above.chunks_exact(8), here.chunks_exact(8));
            for (k, (wa, wb)) in a.by_ref().zip(b.by_ref()).enumerate() {
                let mut x = word(wa) ^ word(wb);
                while x != 0 {
                    found.push((8 * k + (x.trailing_zeros() / 8) as usize, r));
                    x &= x - 1;
                }
            }
            let done = cols - a.remainder().len();
            for (i, (pa, pb)) in a.remainder().iter().zip(b.remainder()).enumerate() {
                if pa != pb {
                    found.push((done + i, r));
                }
            }
        }
        let starts = &mut self.starts;
        starts.clear();
        starts.resize(cols + 1, 0);
        for &(c, _) in found.iter() {
            starts[c + 1] += 1;
        }
        for c in 0..cols {
            starts[c + 1] += starts[c];
        }
        self.fill.clone_from(starts);
        self.rows.clear();
        self.rows.resize(found.len(), 0);
        for &(c, r) in found.iter() {
            self.rows[self.fill[c]] = r;
            self.fill[c] += 1;
        }
    }

    /// The rows where column `col` changes, top down.
    pub(super) fn of_column(&self, col: usize) -> &[usize] {
        match (self.starts.get(col), self.starts.get(col + 1)) {
            (Some(&a), Some(&b)) => self.rows.get(a..b).unwrap_or(&[]),
            _ => &[],
        }
    }
}

/// One little-endian word of 8 bytes.
fn word(chunk: &[u8]) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(chunk);
    u64::from_le_bytes(a)
}
