//! Binary morphology on full-image 0/1 bitmaps with square structuring elements.
//!
//! A `(2r+1)²` square is separable and decomposes into `r` passes of a 3-wide window, each pass
//! a horizontal then a vertical 3-tap min/max written over whole rows, which the compiler
//! vectorises. Pixels outside the image count as foreground for erosion and background for
//! dilation, so an object touching the border neither shrinks from it nor grows into it.

/// Reusable scratch for [`Morphology`] operations on one image size.
#[derive(Debug, Default, Clone)]
pub struct Morphology {
    tmp: Vec<u8>,
}

#[derive(Clone, Copy, PartialEq)]
enum Op {
    Erode,
    Dilate,
}

impl Morphology {
    /// Empty scratch; it grows to the image size on first use.
    pub fn new() -> Self {
        Self::default()
    }

    /// Erodes `bits` (`w·h` bytes of 0/1, row-major) by a `(2r+1)²` square, in place.
    /// Bitmaps of the wrong length are left untouched.
    pub fn erode(&mut self, bits: &mut [u8], w: usize, h: usize, r: u32) {
        for _ in 0..r {
            self.pass(bits, w, h, Op::Erode);
        }
    }

    /// Dilates `bits` by a `(2r+1)²` square, in place.
    pub fn dilate(&mut self, bits: &mut [u8], w: usize, h: usize, r: u32) {
        for _ in 0..r {
            self.pass(bits, w, h, Op::Dilate);
        }
    }

    /// Opening (erosion then dilation): removes specks smaller than the square.
    pub fn open(&mut self, bits: &mut [u8], w: usize, h: usize, r: u32) {
        self.erode(bits, w, h, r);
        self.dilate(bits, w, h, r);
    }

    /// Closing (dilation then erosion): fills holes and gaps narrower than the square.
    pub fn close(&mut self, bits: &mut [u8], w: usize, h: usize, r: u32) {
        self.dilate(bits, w, h, r);
        self.erode(bits, w, h, r);
    }

    fn pass(&mut self, bits: &mut [u8], w: usize, h: usize, op: Op) {
        if w == 0 || h == 0 || bits.len() != w * h {
            return;
        }
        self.tmp.resize(w * h, 0);
        let pad = (op == Op::Erode) as u8;
        let f = |a: u8, b: u8, c: u8| match op {
            Op::Erode => a & b & c,
            Op::Dilate => a | b | c,
        };
        // Horizontal 3-tap into tmp.
        for (src, dst) in bits.chunks_exact(w).zip(self.tmp.chunks_exact_mut(w)) {
            if w == 1 {
                dst[0] = f(pad, src[0], pad);
                continue;
            }
            dst[0] = f(pad, src[0], src[1]);
            dst[w - 1] = f(src[w - 2], src[w - 1], pad);
            let mid = &mut dst[1..w - 1];
            match op {
                Op::Erode => {
                    for (((o, &a), &b), &c) in mid
                        .iter_mut()
                        .zip(&src[..w - 2])
                        .zip(&src[1..w - 1])
                        .zip(&src[2..])
                    {
                        *o = a & b & c;
                    }
                }
                Op::Dilate => {
                    for (((o, &a), &b), &c) in mid
                        .iter_mut()
                        .zip(&src[..w - 2])
                        .zip(&src[1..w - 1])
                        .zip(&src[2..])
                    {
                        *o = a | b | c;
                    }
                }
            }
        }
        // Vertical 3-tap back into bits.
        for y in 0..h {
            let row = &mut bits[y * w..(y + 1) * w];
            let cur = &self.tmp[y * w..(y + 1) * w];
            let up = (y > 0).then(|| &self.tmp[(y - 1) * w..y * w]);
            let down = (y + 1 < h).then(|| &self.tmp[(y + 1) * w..(y + 2) * w]);
            match (up, down, op) {
                (Some(u), Some(d), Op::Erode) => {
                    for (((o, &a), &b), &c) in row.iter_mut().zip(u).zip(cur).zip(d) {
                        *o = a & b & c;
                    }
                }
                (Some(u), Some(d), Op::Dilate) => {
                    for (((o, &a), &b), &c) in row.iter_mut().zip(u).zip(cur).zip(d) {
                        *o = a | b | c;
                    }
                }
                (u, d, _) => {
                    for (x, o) in row.iter_mut().enumerate() {
                        let a = u.map_or(pad, |u| u[x]);
                        let c = d.map_or(pad, |d| d[x]);
                        *o = f(a, cur[x], c);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute-force reference: min/max over the (2r+1)² window with the same border rule.
    fn reference(bits: &[u8], w: usize, h: usize, r: i64, erode: bool) -> Vec<u8> {
        let mut out = vec![0u8; w * h];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let mut acc = erode as u8;
                for dy in -r..=r {
                    for dx in -r..=r {
                        let (xx, yy) = (x + dx, y + dy);
                        let v = if xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
                            erode as u8
                        } else {
                            bits[yy as usize * w + xx as usize]
                        };
                        acc = if erode { acc & v } else { acc | v };
                    }
                }
                out[y as usize * w + x as usize] = acc;
            }
        }
        out
    }

    #[test]
    fn matches_brute_force_on_random_bitmaps() {
        let mut s = 12345u32;
        let mut m = Morphology::new();
        for (w, h) in [(1, 1), (1, 7), (7, 1), (13, 9), (40, 33)] {
            let bits: Vec<u8> = (0..w * h)
                .map(|_| {
                    s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
                    ((s >> 16) % 3 != 0) as u8
                })
                .collect();
            for r in 1..=2 {
                let mut e = bits.clone();
                m.erode(&mut e, w, h, r);
                assert_eq!(
                    e,
                    reference(&bits, w, h, r as i64, true),
                    "erode {w}x{h} r{r}"
                );
                let mut d = bits.clone();
                m.dilate(&mut d, w, h, r);
                assert_eq!(
                    d,
                    reference(&bits, w, h, r as i64, false),
                    "dilate {w}x{h} r{r}"
                );
            }
        }
    }

    #[test]
    fn sparse_bitmaps_match_brute_force() {
        // What a thresholded frame looks like: empty rows, a few objects, specks, foreground on
        // the image's edge columns and rows, where the passes' border rule decides.
        let mut s = 4242u32;
        let mut rnd = |n: u32| {
            s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
            (s >> 16) % n
        };
        let mut m = Morphology::new();
        for (w, h) in [
            (1, 9),
            (2, 6),
            (3, 3),
            (17, 11),
            (40, 30),
            (64, 20),
            (101, 37),
        ] {
            for _ in 0..20 {
                let mut bits = vec![0u8; w * h];
                for _ in 0..rnd(4) {
                    let (x0, y0) = (rnd(w as u32) as usize, rnd(h as u32) as usize);
                    let (x1, y1) = (
                        (x0 + 1 + rnd(12) as usize).min(w),
                        (y0 + 1 + rnd(9) as usize).min(h),
                    );
                    for y in y0..y1 {
                        bits[y * w + x0..y * w + x1].fill(1);
                    }
                }
                for _ in 0..rnd(6) {
                    let i = rnd((w * h) as u32) as usize;
                    bits[i] ^= 1;
                }
                if rnd(2) == 0 {
                    let y = rnd(h as u32) as usize;
                    bits[y * w] = 1;
                    bits[y * w + w - 1] = 1;
                }
                for r in 1..=2 {
                    for erode in [true, false] {
                        let mut got = bits.clone();
                        if erode {
                            m.erode(&mut got, w, h, r);
                        } else {
                            m.dilate(&mut got, w, h, r);
                        }
                        let want = reference(&bits, w, h, r as i64, erode);
                        assert_eq!(got, want, "{w}x{h} r{r} erode {erode}");
                    }
                }
            }
        }
    }

    #[test]
    fn opening_removes_specks_and_closing_fills_holes() {
        let (w, h) = (20, 20);
        let mut bits = vec![0u8; w * h];
        bits[3 * w + 3] = 1; // a speck
        for y in 8..16 {
            for x in 8..16 {
                bits[y * w + x] = 1;
            }
        }
        bits[11 * w + 11] = 0; // a hole
        let mut m = Morphology::new();
        m.open(&mut bits, w, h, 1);
        assert_eq!(bits[3 * w + 3], 0);
        m.close(&mut bits, w, h, 1);
        assert_eq!(bits[11 * w + 11], 1);
        assert_eq!(bits.iter().map(|&v| v as u32).sum::<u32>(), 64);
    }
}
