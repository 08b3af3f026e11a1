//! Grey levels (BT.601 luma) of RGB and RGBA pixels, as the detectors compute them: the
//! background subtractor's model, the moving-camera detector's working frames, the
//! refinement's texture cue. One expression, the same as [`Frame::gray_at`]'s, so that all
//! agree to the bit, with a wasm SIMD path for RGBA rows.

#[cfg(doc)]
use crate::frame::Frame;

/// BT.601 luma, the same expression as [`Frame::gray_at`] so both agree to the bit.
#[inline(always)]
pub(super) fn gray(r: u8, g: u8, b: u8) -> f32 {
    0.299 * r as f32 + 0.587 * g as f32 + 0.114 * b as f32
}

/// The grey levels of one row of `C`-channel pixels (RGB or RGBA), as [`gray`] gives them.
#[inline(always)]
pub(super) fn gray_row<const C: usize>(src: &[u8], z: &mut [f32]) {
    #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
    if C == 4 {
        gray_row_rgba_simd(src, z);
        return;
    }
    for (z, p) in z.iter_mut().zip(src.chunks_exact(C)) {
        *z = gray(p[0], p[1], p[2]);
    }
}

/// [`gray_row`] for RGBA rows with wasm SIMD, four pixels at a time: each pixel is one
/// little-endian `u32` lane, so shifts and masks take its channels apart where the compiler's
/// own vectorisation of the byte loop de-interleaved them lane by lane (a 1080p frame's grey
/// conversion 2.7 → 1.0 ms in Node). The same f32 products and sums in the same order as
/// [`gray`] (wasm SIMD has no fused multiply-add), so the result is the scalar path's to the bit
/// (`tests/detect_simd.rs` compares an RGBA frame's model with its RGB copy's, which takes the
/// scalar path).
#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
fn gray_row_rgba_simd(src: &[u8], z: &mut [f32]) {
    use core::arch::wasm32::{
        f32x4_add, f32x4_convert_i32x4, f32x4_mul, f32x4_splat, u32x4_shr, u32x4_splat, v128,
        v128_and, v128_load, v128_store,
    };
    let (kr, kg, kb) = (f32x4_splat(0.299), f32x4_splat(0.587), f32x4_splat(0.114));
    let byte = u32x4_splat(0xff);
    let mut px = src.chunks_exact(16);
    let mut out = z.chunks_exact_mut(4);
    for (p, o) in (&mut px).zip(&mut out) {
        // SAFETY: `p` holds 16 bytes and `o` 4 f32s (16 bytes); unaligned loads and stores
        // are allowed by wasm.
        let v = unsafe { v128_load(p.as_ptr() as *const v128) };
        let r = f32x4_convert_i32x4(v128_and(v, byte));
        let g = f32x4_convert_i32x4(v128_and(u32x4_shr(v, 8), byte));
        let b = f32x4_convert_i32x4(v128_and(u32x4_shr(v, 16), byte));
        let y = f32x4_add(
            f32x4_add(f32x4_mul(kr, r), f32x4_mul(kg, g)),
            f32x4_mul(kb, b),
        );
        // SAFETY: as above.
        unsafe { v128_store(o.as_mut_ptr() as *mut v128, y) };
    }
    for (z, p) in out
        .into_remainder()
        .iter_mut()
        .zip(px.remainder().chunks_exact(4))
    {
        *z = gray(p[0], p[1], p[2]);
    }
}
