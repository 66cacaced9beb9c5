//! The AVX2 + FMA product kernel of `gemm` (x86-64, checked at run time: `super::resolve`),
//! for the CPUs without AVX-512 (most desktops and laptops): the same contract and the same
//! epilogues as `avx512`, with tiles sized for 16 registers.
//!
//! A tile is 6 rows x 16 columns of the result in 12 registers: per step along k, two loads of
//! the right operand and six broadcasts of the left one feed 12 fused multiply-adds (15
//! registers live; the epilogue runs out of line so its constants do not take any).

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
    for t in 0..row_tiles * col_tiles {
        let (ti, tj) =
            if wide { (t % row_tiles, t / row_tiles) } else { (t / col_tiles, t % col_tiles) };
        let (i0, j0) = (ti * MR, tj * NR);
        let rows = MR.min(m - i0);
        // SAFETY: the tile lies inside the m x n result and reads rows i0..i0+rows of a and
        // columns j0..j0+16 of b (the caller's contract).
        unsafe {
            match (rows, wide && ti == 0) {
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
}

/// How far ahead of its panel (in floats: four panels) a wide product's tile prefetches b.
const AHEAD: usize = 4 * NR;

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
        }
    }
}

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
unsafe fn load(p: *const f32) -> __m256 {
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
unsafe fn store(p: *mut f32, v: __m256) {
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

/// out[i * r + j] = beta out[i * r + j] + a_i . rows_j for a [m x k] and rows [r x k], both
/// row-major: products with a handful of columns (a layer of width 1 or 3), and the heads'
/// a b^T.
///
/// # Safety
/// The CPU has AVX2 and FMA; a holds m x k, rows r x k, out m x r.
#[target_feature(enable = "avx2,fma")]
pub unsafe fn dots(
    m: usize,
    k: usize,
    r: usize,
    a: *const f32,
    rows: *const f32,
    beta: f32,
    out: *mut f32,
) {
    let mut i = 0;
    // SAFETY (whole body): rows i.. of a and of out lie inside their buffers.
    unsafe {
        while i + DOT_ROWS <= m {
            dots_rows::<DOT_ROWS>(k, r, a.add(i * k), rows, beta, out.add(i * r));
            i += DOT_ROWS;
        }
        while i < m {
            dots_rows::<1>(k, r, a.add(i * k), rows, beta, out.add(i * r));
            i += 1;
        }
    }
}

/// Rows of a that [`dots`] takes together: each row's two accumulator chains wait on their
/// last fused multiply-add, so four rows (eight chains, in 16 registers with the loads) keep
/// both FMA ports busy.
const DOT_ROWS: usize = 4;

/// [`dots`] for R consecutive rows of a: each row's accumulators see the same sequence of
/// fused multiply-adds and the same reduction as one row alone, so the result is the same to
/// the bit whatever R.
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn dots_rows<const R: usize>(
    k: usize,
    r: usize,
    a: *const f32,
    rows: *const f32,
    beta: f32,
    out: *mut f32,
) {
    let tail = k % 8;
    let full = k - tail;
    // Lane l of the tail's mask is set when l < tail.
    let mask = _mm256_cmpgt_epi32(
        _mm256_set1_epi32(tail as i32),
        _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
    );
    // SAFETY (whole body): the R rows of a, every row of `rows` and out's R rows lie inside
    // their buffers (the caller's contract).
    unsafe {
        for j in 0..r {
            let bj = rows.add(j * k);
            let mut acc0 = [_mm256_setzero_ps(); R];
            let mut acc1 = [_mm256_setzero_ps(); R];
            let mut p = 0;
            while p + 16 <= full {
                let (b0, b1) = (load(bj.add(p)), load(bj.add(p + 8)));
                for d in 0..R {
                    let ad = a.add(d * k + p);
                    acc0[d] = _mm256_fmadd_ps(load(ad), b0, acc0[d]);
                    acc1[d] = _mm256_fmadd_ps(load(ad.add(8)), b1, acc1[d]);
                }
                p += 16;
            }
            if p < full {
                let b0 = load(bj.add(p));
                for (d, acc0) in acc0.iter_mut().enumerate() {
                    *acc0 = _mm256_fmadd_ps(load(a.add(d * k + p)), b0, *acc0);
                }
            }
            if tail > 0 {
                let b1 = _mm256_maskload_ps(bj.add(full), mask);
                for (d, acc1) in acc1.iter_mut().enumerate() {
                    *acc1 =
                        _mm256_fmadd_ps(_mm256_maskload_ps(a.add(d * k + full), mask), b1, *acc1);
                }
            }
            for d in 0..R {
                let o = out.add(d * r + j);
                let s = sum(_mm256_add_ps(acc0[d], acc1[d]));
                *o = if beta == 0.0 { s } else { *o + s };
            }
        }
    }
}

/// The sum of 8 lanes.
#[target_feature(enable = "avx2")]
#[inline]
fn sum(v: __m256) -> f32 {
    let s = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
    let s = _mm_add_ps(s, _mm_movehl_ps(s, s));
    let s = _mm_add_ss(s, _mm_shuffle_ps::<0b01>(s, s));
    _mm_cvtss_f32(s)
}

/// Elements of k per pass of [`dots_wide`]: a chunk of a's rows (3 KB each, 24 KB for the
/// heads' 8 poses) stays in L1 while every row of `rows` streams its chunk once.
const KC: usize = 768;

/// Rows of `rows` ahead whose chunk [`dots_wide`] prefetches while it reads a row's: each chunk
/// lies a row (a page or more) from the last, where the hardware prefetcher starts cold
/// (with KC 2,048 and no prefetch: 10 ms for the paper's head, 8 x 65,792 x 256; 3.7 ms now).
const ROWS_AHEAD: usize = 2;

/// [`dots`] for a long k (the heads' d_out W^T: a few poses times 65,792 outputs against
/// hundreds of rows): k in chunks of [`KC`], every row of `rows` read once from memory (the
/// row-by-row loop reads it once per row of a), four rows of a at a time against it.
///
/// # Safety
/// The CPU has AVX2 and FMA; a holds m x k, rows r x k, out m x r.
#[target_feature(enable = "avx2,fma")]
pub unsafe fn dots_wide(
    m: usize,
    k: usize,
    r: usize,
    a: *const f32,
    rows: *const f32,
    beta: f32,
    out: *mut f32,
) {
    // SAFETY (whole body): every offset stays inside a (m x k), rows (r x k) and out (m x r);
    // the prefetched addresses are only hints (null when past the last row).
    unsafe {
        if beta == 0.0 {
            std::ptr::write_bytes(out, 0, m * r);
        }
        let mut c0 = 0;
        while c0 < k {
            let len = KC.min(k - c0);
            for j in 0..r {
                let bj = rows.add(j * k + c0);
                let ahead = j + ROWS_AHEAD;
                let mut next = if ahead < r { rows.add(ahead * k + c0) } else { std::ptr::null() };
                let mut i = 0;
                while i < m {
                    let at = |d: usize| a.add((i + d) * k + c0);
                    let o = out.add(i * r + j);
                    match m - i {
                        1 => dots_block::<1>(len, [at(0)], bj, o, r, next),
                        2 => dots_block::<2>(len, [at(0), at(1)], bj, o, r, next),
                        3 => dots_block::<3>(len, [at(0), at(1), at(2)], bj, o, r, next),
                        _ => dots_block::<4>(len, [at(0), at(1), at(2), at(3)], bj, o, r, next),
                    }
                    next = std::ptr::null();
                    i += 4;
                }
            }
            c0 += len;
        }
    }
}

/// out[d * r] += a_d . b over `len` elements for R rows a_d (a [`dots_wide`] block),
/// prefetching `next`'s `len` elements unless null.
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
unsafe fn dots_block<const R: usize>(
    len: usize,
    a: [*const f32; R],
    b: *const f32,
    out: *mut f32,
    r: usize,
    next: *const f32,
) {
    let tail = (len % 8) as i32;
    let mask =
        _mm256_cmpgt_epi32(_mm256_set1_epi32(tail), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    let full = len - len % 8;
    // SAFETY (whole body): a_d and b hold len elements, out[d * r] lies in the result.
    unsafe {
        let mut acc = [[_mm256_setzero_ps(); 2]; R];
        let mut p = 0;
        while p + 16 <= full {
            if !next.is_null() {
                _mm_prefetch::<_MM_HINT_T0>(next.wrapping_add(p).cast());
            }
            let (b0, b1) = (load(b.add(p)), load(b.add(p + 8)));
            for d in 0..R {
                acc[d][0] = _mm256_fmadd_ps(load(a[d].add(p)), b0, acc[d][0]);
                acc[d][1] = _mm256_fmadd_ps(load(a[d].add(p + 8)), b1, acc[d][1]);
            }
            p += 16;
        }
        if p < full {
            let b0 = load(b.add(p));
            for d in 0..R {
                acc[d][0] = _mm256_fmadd_ps(load(a[d].add(p)), b0, acc[d][0]);
            }
        }
        if tail > 0 {
            let x = b.add(full);
            let b1 = _mm256_maskload_ps(x, mask);
            for d in 0..R {
                let x = a[d].add(full);
                acc[d][1] = _mm256_fmadd_ps(_mm256_maskload_ps(x, mask), b1, acc[d][1]);
            }
        }
        for (d, acc) in acc.iter().enumerate() {
            *out.add(d * r) += sum(_mm256_add_ps(acc[0], acc[1]));
        }
    }
}
