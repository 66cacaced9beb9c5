//! The AVX2 + FMA product kernel of `gemm` (x86-64, checked at run time: `super::resolve`),
//! for the CPUs without AVX-512 (most desktops and laptops): the same contract and the same
//! epilogues as `avx512`, with tiles sized for 16 registers.
//!
//! A tile is 6 rows x 16 columns of the result in 12 registers: per step along k, two loads of
//! the right operand and six broadcasts of the left one feed 12 fused multiply-adds (15
//! registers live; the epilogue runs out of line so its constants do not take any). The dot
//! products (a b^T) are in `avx2_dots`.

use super::Raw;
use std::arch::x86_64::*;

const MR: usize = 6;
const NR: usize = 16;

/// out (m x n, row-major) = epilogue(a b); a element (i, p) at a[i * rsa + p * csa]; b
/// row-major k x n; n a multiple of 16.
///
/// # Safety
/// The CPU has AVX2 and FMA; a's strides address its m x k view inside its buffer; b holds
/// k x n; out and every epilogue pointer hold m x n (bias: n).
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
pub unsafe fn gemm(
    m: usize,
    k: usize,
    n: usize,
    a: *const f32,
    rsa: isize,
    csa: isize,
    b: *const f32,
    out: *mut f32,
    ep: Raw,
) {
    // Row tiles outside, column tiles inside: consecutive tiles' epilogues touch consecutive
    // memory (the activations of a block of the paper's SIREN live in L3, and the prefetcher
    // follows rows). When m is at most two tiles (the heads' products: 8 poses times a
    // 65,792-wide output), column panels outside instead, so b is read from memory once, and
    // the first row tile prefetches the panel [`AHEAD`] floats on: its k rows are a page
    // apart each, too many streams for the hardware prefetcher (10.5 -> 4.5 ms for the
    // paper's head, 8 x 256 x 65,792).
    let (row_tiles, col_tiles) = (m.div_ceil(MR), n / NR);
    let wide = m <= 2 * MR;
    // A transposed left operand (the weight gradients' h^T v) is read a column at a time,
    // k rows a line apart each: a row tile's strip is copied into `strip` (k x 6, one line
    // per step along k) once for all its column tiles (111 -> 116 GFLOP/s at 256 x 128 x 256).
    let pack = csa != 1 && !wide && col_tiles >= 4;
    let mut strip = if pack { vec![0f32; MR * k + 2] } else { Vec::new() };
    let mut packed = usize::MAX;
    for t in 0..row_tiles * col_tiles {
        let (ti, tj) =
            if wide { (t % row_tiles, t / row_tiles) } else { (t / col_tiles, t % col_tiles) };
        let (i0, rows) = row_tile(m, ti);
        let j0 = tj * NR;
        let (mut a, mut rsa, mut csa) = (a, rsa, csa);
        if pack {
            if packed != ti {
                // SAFETY: rows i0..i0 + rows of a's k columns (masked lanes are not read), into
                // a strip of 6 k + 2 floats.
                unsafe { pack_strip(k, a.wrapping_add(i0), csa, rows, strip.as_mut_ptr()) };
                packed = ti;
            }
            // Row i0 + d of the tile at strip[d].
            (a, rsa, csa) = (strip.as_ptr().wrapping_sub(i0), 1, MR as isize);
        }
        // SAFETY: the tile lies inside the m x n result and reads rows i0..i0+rows of a (or
        // their strip) and columns j0..j0+16 of b (the caller's contract).
        unsafe { tile_of(rows, wide && ti == 0, k, n, a, rsa, csa, b, out, ep, i0, j0) };
    }
}

/// [`tile`] of `rows` rows, out of line: without target features of its own, so the kernel
/// cannot be inlined into it nor it into `gemm` (rustc 1.95 drops `#[inline(never)]` on a
/// function with target features, and `gemm` with its tiles inlined kept their accumulators
/// on the stack: 120 -> 65 GFLOP/s).
///
/// # Safety
/// As [`tile`]'s.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
unsafe fn tile_of(
    rows: usize,
    prefetch: bool,
    k: usize,
    n: usize,
    a: *const f32,
    rsa: isize,
    csa: isize,
    b: *const f32,
    out: *mut f32,
    ep: Raw,
    i0: usize,
    j0: usize,
) {
    // SAFETY: the caller's contract; it has checked AVX2 and FMA.
    unsafe {
        match (rows, prefetch) {
            (6, true) => tile::<6, true>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            (6, _) => tile::<6, false>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            (5, true) => tile::<5, true>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            (5, _) => tile::<5, false>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            (4, true) => tile::<4, true>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            (4, _) => tile::<4, false>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            (3, true) => tile::<3, true>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            (3, _) => tile::<3, false>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            (2, true) => tile::<2, true>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            (2, _) => tile::<2, false>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            (_, true) => tile::<1, true>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            (_, _) => tile::<1, false>(k, n, a, rsa, csa, b, out, ep, i0, j0),
        }
    }
}

/// (first row, rows) of row tile `ti` of m rows: tiles of 6, but a last tile of one or two
/// rows (4 or 2 chains of fused multiply-adds, too few to fill both FMA units) shares the
/// rows of the tile before it as 4 + 3 or 4 + 4 (128 = 20 x 6 + 4 + 4). Each element's sum
/// is the same whatever its tile's height.
fn row_tile(m: usize, ti: usize) -> (usize, usize) {
    let (full, rem) = (m / MR, m % MR);
    if (rem == 1 || rem == 2) && full >= 1 && ti + 1 >= full {
        let i0 = (full - 1) * MR;
        return if ti + 1 == full { (i0, 4) } else { (i0 + 4, MR + rem - 4) };
    }
    (ti * MR, MR.min(m - ti * MR))
}

/// Copies `rows` (at most 6) rows of a's k columns, starting at `a` with row stride 1 and
/// column stride `csa`, into `strip` as k steps of 6 floats.
///
/// # Safety
/// The CPU has AVX2; a addresses those rows and columns; strip holds 6 k + 2 floats.
#[target_feature(enable = "avx2")]
unsafe fn pack_strip(k: usize, a: *const f32, csa: isize, rows: usize, strip: *mut f32) {
    let lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let mask = _mm256_cmpgt_epi32(_mm256_set1_epi32(rows as i32), lanes);
    // SAFETY: masked lanes are not read; the 8-float stores end within 6 k + 2.
    unsafe {
        for p in 0..k {
            let v = _mm256_maskload_ps(a.wrapping_offset(csa.wrapping_mul(p as isize)), mask);
            store(strip.add(MR * p), v);
        }
    }
}

/// How far ahead of its panel (in floats: four panels) a wide product's tile prefetches b.
const AHEAD: usize = 4 * NR;

/// Rows i0.. (R of them) and columns j0..j0 + 16 of the result.
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
#[inline(never)]
unsafe fn tile<const R: usize, const PREFETCH: bool>(
    k: usize,
    n: usize,
    a: *const f32,
    rsa: isize,
    csa: isize,
    b: *const f32,
    out: *mut f32,
    ep: Raw,
    i0: usize,
    j0: usize,
) {
    // SAFETY (whole body): indices stay within the caller's m x k, k x n and m x n views.
    // Pointer steps use wrapping arithmetic (no overflow checks in the dev profile's inner
    // loop).
    unsafe {
        let mut acc = [[_mm256_setzero_ps(); 2]; R];
        let rows: [*const f32; R] =
            std::array::from_fn(|d| a.wrapping_offset(rsa.wrapping_mul((i0 + d) as isize)));
        let mut a_step: isize = 0;
        let mut bp = b.wrapping_add(j0);
        for _ in 0..k {
            if PREFETCH {
                _mm_prefetch::<_MM_HINT_T0>(bp.wrapping_add(AHEAD).cast());
            }
            let b0 = load(bp);
            let b1 = load(bp.wrapping_add(8));
            for d in 0..R {
                // A load intrinsic, not a dereference (the dev profile checks those).
                let av = _mm256_broadcastss_ps(_mm_load_ss(rows[d].wrapping_offset(a_step)));
                acc[d][0] = _mm256_fmadd_ps(av, b0, acc[d][0]);
                acc[d][1] = _mm256_fmadd_ps(av, b1, acc[d][1]);
            }
            a_step = a_step.wrapping_add(csa);
            bp = bp.wrapping_add(n);
        }
        epilogue::<R>(&acc, n, out, ep, i0, j0);
    }
}

/// A tile's epilogue over its accumulators (rows i0.., columns j0..j0 + 16), out of line (its
/// constants would otherwise take registers from the products' inner loop), one per tile
/// height so its loops unroll.
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
unsafe fn epilogue<const R: usize>(
    acc: &[[__m256; 2]; R],
    n: usize,
    out: *mut f32,
    ep: Raw,
    i0: usize,
    j0: usize,
) {
    let set = _mm256_set1_ps;
    let tile_at =
        |d: usize, v: usize| (i0 + d).wrapping_mul(n).wrapping_add(j0).wrapping_add(8 * v);
    // SAFETY (whole body): the tile lies inside the result and every buffer laid out like it
    // (the caller's contract).
    unsafe {
        match ep {
            Raw::Store { beta } => {
                for (d, acc) in acc.iter().enumerate() {
                    for (v, &p) in acc.iter().enumerate() {
                        let o = out.add(tile_at(d, v));
                        store(o, if beta == 0.0 { p } else { _mm256_add_ps(load(o), p) });
                    }
                }
            }
            Raw::Sine { w0, bias, deriv } => {
                let bias = [load(bias.add(j0)), load(bias.add(j0 + 8))];
                for (d, acc) in acc.iter().enumerate() {
                    for (v, &p) in acc.iter().enumerate() {
                        let at = tile_at(d, v);
                        let (s, c) = sin_cos(_mm256_mul_ps(set(w0), _mm256_add_ps(p, bias[v])));
                        store(out.add(at), s);
                        store(deriv.add(at), _mm256_mul_ps(set(w0), c));
                    }
                }
            }
            Raw::AlsoTimes { factor, times } => {
                for (d, acc) in acc.iter().enumerate() {
                    for (v, &p) in acc.iter().enumerate() {
                        let at = tile_at(d, v);
                        store(out.add(at), p);
                        store(times.add(at), _mm256_mul_ps(p, load(factor.add(at))));
                    }
                }
            }
            Raw::GradChain { scale, v: vb, h, c } => {
                for (d, acc) in acc.iter().enumerate() {
                    for (v, &p) in acc.iter().enumerate() {
                        let at = tile_at(d, v);
                        let t = _mm256_mul_ps(_mm256_mul_ps(set(scale), p), load(vb.add(at)));
                        store(vb.add(at), _mm256_mul_ps(t, load(h.add(at))));
                        store(out.add(at), _mm256_mul_ps(p, load(c.add(at))));
                    }
                }
            }
            Raw::AddTimes { factor } => {
                for (d, acc) in acc.iter().enumerate() {
                    for (v, &p) in acc.iter().enumerate() {
                        let o = out.add(tile_at(d, v));
                        store(o, _mm256_fmadd_ps(p, load(factor.add(tile_at(d, v))), load(o)));
                    }
                }
            }
            Raw::Adam { m, v: vm, step } => {
                let ([b1, b2], ahead) = (super::super::adam_step::BETAS, ADAM_AHEAD);
                for (d, acc) in acc.iter().enumerate() {
                    for (v, &g) in acc.iter().enumerate() {
                        let at = tile_at(d, v);
                        let (po, mo, vo) = (out.add(at), m.add(at), vm.add(at));
                        if v == 0 {
                            for x in [po, mo, vo] {
                                _mm_prefetch::<_MM_HINT_T0>(x.wrapping_add(ahead).cast());
                            }
                        }
                        // adam_update's operations in its order, unfused: the same bits.
                        let gm = _mm256_mul_ps(g, set(1.0 - b1));
                        let gv = _mm256_mul_ps(_mm256_mul_ps(g, g), set(1.0 - b2));
                        let (m1, v1) = if step.first {
                            (gm, gv)
                        } else {
                            let m0 = _mm256_mul_ps(load(mo), set(b1));
                            (
                                _mm256_add_ps(m0, gm),
                                _mm256_add_ps(_mm256_mul_ps(load(vo), set(b2)), gv),
                            )
                        };
                        store(mo, m1);
                        store(vo, v1);
                        let den = _mm256_add_ps(_mm256_sqrt_ps(v1), set(step.eps));
                        let q = _mm256_div_ps(_mm256_mul_ps(m1, set(step.factor)), den);
                        store(po, _mm256_sub_ps(load(po), _mm256_mul_ps(set(step.lr), q)));
                    }
                }
            }
        }
    }
}

/// How far ahead (in floats) the Adam epilogue prefetches its rows of parameters and moments:
/// the row tiles' next tiles along the row (18 streams for a 6-row tile, more than the
/// hardware prefetcher follows).
const ADAM_AHEAD: usize = 8 * NR;

/// All eight lanes of a masked move.
#[cfg(debug_assertions)]
#[target_feature(enable = "avx2")]
#[inline]
fn all_lanes() -> __m256i {
    _mm256_set1_epi32(-1)
}

/// 8 floats from `p` (any alignment). In the dev profile a masked move: the plain one is a
/// checked copy there (through the stack), which halves the kernel; the same value either way.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn load(p: *const f32) -> __m256 {
    // SAFETY: the caller's pointer addresses 8 floats.
    unsafe {
        #[cfg(debug_assertions)]
        {
            _mm256_maskload_ps(p, all_lanes())
        }
        #[cfg(not(debug_assertions))]
        {
            _mm256_loadu_ps(p)
        }
    }
}

#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn store(p: *mut f32, v: __m256) {
    // SAFETY: the caller's pointer addresses 8 floats.
    unsafe {
        #[cfg(debug_assertions)]
        {
            _mm256_maskstore_ps(p, all_lanes(), v)
        }
        #[cfg(not(debug_assertions))]
        {
            _mm256_storeu_ps(p, v)
        }
    }
}

/// `crate::model::sine::sin_cos` on 8 lanes (the same reduction and polynomials, with fused
/// multiply-adds, as `avx512::sin_cos`).
#[target_feature(enable = "avx2,fma")]
#[inline]
pub fn sin_cos(x: __m256) -> (__m256, __m256) {
    let set = _mm256_set1_ps;
    let round = set(12_582_912.0);
    let shifted = _mm256_fmadd_ps(x, set(std::f32::consts::FRAC_1_PI), round);
    let k = _mm256_sub_ps(shifted, round);
    let odd = _mm256_slli_epi32::<31>(_mm256_castps_si256(shifted));
    let r = _mm256_fnmadd_ps(k, set(3.140_625), x);
    #[allow(clippy::excessive_precision)] // the digits of pi - 3.140625
    let r = _mm256_fnmadd_ps(k, set(9.676_535_5e-4), r);
    let r2 = _mm256_mul_ps(r, r);
    let mut s = set(-1.0 / 39_916_800.0);
    for c in [1.0 / 362_880.0, -1.0 / 5040.0, 1.0 / 120.0, -1.0 / 6.0] {
        s = _mm256_fmadd_ps(s, r2, set(c));
    }
    let sin_r = _mm256_fmadd_ps(_mm256_mul_ps(r, r2), s, r);
    let mut c = set(1.0 / 479_001_600.0);
    for k in [-1.0 / 3_628_800.0, 1.0 / 40_320.0, -1.0 / 720.0, 1.0 / 24.0, -0.5, 1.0] {
        c = _mm256_fmadd_ps(c, r2, set(k));
    }
    let odd = _mm256_castsi256_ps(odd);
    (_mm256_xor_ps(sin_r, odd), _mm256_xor_ps(c, odd))
}
