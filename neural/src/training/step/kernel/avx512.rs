//! The AVX-512 product kernel of `gemm` (x86-64, checked at run time: `super::resolve`): reads both operands in
//! place (no packing: the training step's products are too skinny for packing to pay) and
//! finishes each tile in registers with the product's epilogue, so a sine layer's
//! pre-activation, or the adjoint it feeds, never goes to memory.
//!
//! A tile is 12 rows x 32 columns of the result in 24 registers: per step along k, two loads
//! of the right operand and twelve broadcasts of the left one feed 24 fused multiply-adds.

use super::Raw;
use std::arch::x86_64::*;

const MR: usize = 12;
const NR: usize = 32;

/// out (m x n, row-major) = epilogue(a b); a element (i, p) at a[i * rsa + p * csa]; b
/// row-major k x n; n a multiple of 32.
///
/// # Safety
/// The CPU has AVX-512F; a's strides address its m x k view inside its buffer; b holds k x n;
/// out and every epilogue pointer hold m x n (bias: n).
#[target_feature(enable = "avx512f")]
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
    let mut i0 = 0;
    while i0 < m {
        let rows = MR.min(m - i0);
        let mut j0 = 0;
        while j0 < n {
            // SAFETY: the tile lies inside the m x n result and reads rows i0..i0+rows of a and
            // columns j0..j0+32 of b (the caller's contract).
            unsafe { tile_of(rows, k, n, a, rsa, csa, b, out, ep, i0, j0) };
            j0 += NR;
        }
        i0 += MR;
    }
}

/// [`tile`] of `rows` rows, out of line: without target features of its own, so the kernel
/// cannot be inlined into it nor it into `gemm` (rustc 1.95 drops `#[inline(never)]` on a
/// function with target features; `avx2::tile_of` is the same shim).
///
/// # Safety
/// As [`tile`]'s.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
unsafe fn tile_of(
    rows: usize,
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
    // SAFETY: the caller's contract; it has checked AVX-512F.
    unsafe {
        match rows {
            12 => tile::<12>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            11 => tile::<11>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            10 => tile::<10>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            9 => tile::<9>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            8 => tile::<8>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            7 => tile::<7>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            6 => tile::<6>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            5 => tile::<5>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            4 => tile::<4>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            3 => tile::<3>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            2 => tile::<2>(k, n, a, rsa, csa, b, out, ep, i0, j0),
            _ => tile::<1>(k, n, a, rsa, csa, b, out, ep, i0, j0),
        }
    }
}

#[target_feature(enable = "avx512f")]
#[allow(clippy::too_many_arguments)]
#[inline(never)]
unsafe fn tile<const R: usize>(
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
    // Pointer steps use wrapping arithmetic: the dev profile's overflow checks in the inner
    // loop kept the accumulators out of registers.
    unsafe {
        let mut acc = [[_mm512_setzero_ps(); 2]; R];
        let rows: [*const f32; R] =
            std::array::from_fn(|d| a.wrapping_offset(rsa.wrapping_mul((i0 + d) as isize)));
        let mut a_step: isize = 0;
        let mut bp = b.wrapping_add(j0);
        for _ in 0..k {
            let b0 = load(bp);
            let b1 = load(bp.wrapping_add(16));
            for d in 0..R {
                // A load intrinsic, not a dereference: the dev profile checks every dereference's
                // alignment, and those branches pushed accumulators out of registers.
                let av = _mm512_broadcastss_ps(_mm_load_ss(rows[d].wrapping_offset(a_step)));
                acc[d][0] = _mm512_fmadd_ps(av, b0, acc[d][0]);
                acc[d][1] = _mm512_fmadd_ps(av, b1, acc[d][1]);
            }
            a_step = a_step.wrapping_add(csa);
            bp = bp.wrapping_add(n);
        }
        epilogue(&acc, n, out, ep, i0, j0);
    }
}

/// A tile's epilogue over its accumulators (rows i0.., columns j0..j0 + 32), out of line: its
/// constants (the sine's polynomial) would otherwise stay in registers across the products'
/// inner loop and push accumulators onto the stack.
#[target_feature(enable = "avx512f")]
#[inline(never)]
unsafe fn epilogue(acc: &[[__m512; 2]], n: usize, out: *mut f32, ep: Raw, i0: usize, j0: usize) {
    let set = _mm512_set1_ps;
    let tile_at =
        |d: usize, v: usize| (i0 + d).wrapping_mul(n).wrapping_add(j0).wrapping_add(16 * v);
    // SAFETY (whole body): the tile lies inside the result and every buffer laid out like it
    // (the caller's contract).
    unsafe {
        match ep {
            Raw::Store { beta } => {
                for (d, acc) in acc.iter().enumerate() {
                    for (v, &p) in acc.iter().enumerate() {
                        let o = out.add(tile_at(d, v));
                        store(o, if beta == 0.0 { p } else { _mm512_add_ps(load(o), p) });
                    }
                }
            }
            Raw::Sine { w0, bias, deriv } => {
                let bias = [load(bias.add(j0)), load(bias.add(j0 + 16))];
                for (d, acc) in acc.iter().enumerate() {
                    for (v, &p) in acc.iter().enumerate() {
                        let at = tile_at(d, v);
                        let (s, c) = sin_cos(_mm512_mul_ps(set(w0), _mm512_add_ps(p, bias[v])));
                        store(out.add(at), s);
                        store(deriv.add(at), _mm512_mul_ps(set(w0), c));
                    }
                }
            }
            Raw::AlsoTimes { factor, times } => {
                for (d, acc) in acc.iter().enumerate() {
                    for (v, &p) in acc.iter().enumerate() {
                        let at = tile_at(d, v);
                        store(out.add(at), p);
                        store(times.add(at), _mm512_mul_ps(p, load(factor.add(at))));
                    }
                }
            }
            Raw::GradChain { scale, v: vb, h, c } => {
                for (d, acc) in acc.iter().enumerate() {
                    for (v, &p) in acc.iter().enumerate() {
                        let at = tile_at(d, v);
                        let t = _mm512_mul_ps(_mm512_mul_ps(set(scale), p), load(vb.add(at)));
                        store(vb.add(at), _mm512_mul_ps(t, load(h.add(at))));
                        store(out.add(at), _mm512_mul_ps(p, load(c.add(at))));
                    }
                }
            }
            Raw::AddTimes { factor } => {
                for (d, acc) in acc.iter().enumerate() {
                    for (v, &p) in acc.iter().enumerate() {
                        let o = out.add(tile_at(d, v));
                        store(o, _mm512_fmadd_ps(p, load(factor.add(tile_at(d, v))), load(o)));
                    }
                }
            }
            Raw::Adam { .. } => unreachable!("weight_adam runs Adam's epilogue on the AVX2 kernel"),
        }
    }
}

/// 16 floats from `p` (any alignment). Masked moves, not `_mm512_loadu_ps`: the dev profile
/// checks the plain ones' pointers and copies through the stack, which took half the kernel.
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn load(p: *const f32) -> __m512 {
    // SAFETY: the caller's pointer addresses 16 floats.
    unsafe { _mm512_maskz_loadu_ps(0xFFFF, p) }
}

#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn store(p: *mut f32, v: __m512) {
    // SAFETY: the caller's pointer addresses 16 floats.
    unsafe { _mm512_mask_storeu_ps(p, 0xFFFF, v) }
}

/// `crate::model::sine::sin_cos` on 16 lanes (the same reduction and polynomials, with fused
/// multiply-adds).
#[target_feature(enable = "avx512f")]
#[inline]
pub fn sin_cos(x: __m512) -> (__m512, __m512) {
    let set = _mm512_set1_ps;
    let round = set(12_582_912.0);
    let shifted = _mm512_fmadd_ps(x, set(std::f32::consts::FRAC_1_PI), round);
    let k = _mm512_sub_ps(shifted, round);
    let odd = _mm512_slli_epi32::<31>(_mm512_castps_si512(shifted));
    let r = _mm512_fnmadd_ps(k, set(3.140_625), x);
    #[allow(clippy::excessive_precision)] // the digits of pi - 3.140625
    let r = _mm512_fnmadd_ps(k, set(9.676_535_5e-4), r);
    let r2 = _mm512_mul_ps(r, r);
    let mut s = set(-1.0 / 39_916_800.0);
    for c in [1.0 / 362_880.0, -1.0 / 5040.0, 1.0 / 120.0, -1.0 / 6.0] {
        s = _mm512_fmadd_ps(s, r2, set(c));
    }
    let sin_r = _mm512_fmadd_ps(_mm512_mul_ps(r, r2), s, r);
    let mut c = set(1.0 / 479_001_600.0);
    for k in [-1.0 / 3_628_800.0, 1.0 / 40_320.0, -1.0 / 720.0, 1.0 / 24.0, -0.5, 1.0] {
        c = _mm512_fmadd_ps(c, r2, set(k));
    }
    let sin = _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(sin_r), odd));
    let cos = _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(c), odd));
    (sin, cos)
}

/// out[i * r + j] = beta out[i * r + j] + a_i . rows_j for a [m x k] and rows [r x k], both
/// row-major: products with a handful of columns (a layer of width 1 or 3).
///
/// # Safety
/// The CPU has AVX-512F; a holds m x k, rows r x k, out m x r.
#[target_feature(enable = "avx512f")]
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

/// Rows of a that [`dots`] takes together: one accumulator's chain of fused multiply-adds
/// waits on the last one (4 cycles), so eight rows' chains keep both FMA ports busy.
const DOT_ROWS: usize = 8;

/// [`dots`] for R consecutive rows of a: each row's accumulator sees the same sequence of
/// fused multiply-adds and the same reduction as one row alone, so the result is the same to
/// the bit whatever R.
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn dots_rows<const R: usize>(
    k: usize,
    r: usize,
    a: *const f32,
    rows: *const f32,
    beta: f32,
    out: *mut f32,
) {
    let tail = (k % 16) as u32;
    let mask: __mmask16 = ((1u32 << tail) - 1) as u16;
    let full = k - k % 16;
    // SAFETY (whole body): the R rows of a, every row of `rows` and out's R rows lie inside
    // their buffers (the caller's contract).
    unsafe {
        for j in 0..r {
            let bj = rows.add(j * k);
            let mut acc = [_mm512_setzero_ps(); R];
            let mut p = 0;
            while p < full {
                let b = load(bj.add(p));
                for (d, acc) in acc.iter_mut().enumerate() {
                    *acc = _mm512_fmadd_ps(load(a.add(d * k + p)), b, *acc);
                }
                p += 16;
            }
            if tail > 0 {
                let b = _mm512_maskz_loadu_ps(mask, bj.add(full));
                for (d, acc) in acc.iter_mut().enumerate() {
                    *acc =
                        _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mask, a.add(d * k + full)), b, *acc);
                }
            }
            for (d, acc) in acc.into_iter().enumerate() {
                let o = out.add(d * r + j);
                let s = _mm512_reduce_add_ps(acc);
                *o = if beta == 0.0 { s } else { *o + s };
            }
        }
    }
}

/// Elements of k per pass of [`dots_wide`]: a chunk of a's rows (8 KB each) stays in cache
/// while every row of `rows` streams its chunk once.
const KC: usize = 2048;

/// [`dots`] for a long k (the heads' d_out W^T: a few poses times 65,792 outputs against
/// hundreds of rows): k in chunks of [`KC`], every row of `rows` read once from memory (the
/// row-by-row loop reads it once per row of a), four rows of a at a time against it.
///
/// # Safety
/// The CPU has AVX-512F; a holds m x k, rows r x k, out m x r.
#[target_feature(enable = "avx512f")]
pub unsafe fn dots_wide(
    m: usize,
    k: usize,
    r: usize,
    a: *const f32,
    rows: *const f32,
    beta: f32,
    out: *mut f32,
) {
    // SAFETY (whole body): every offset stays inside a (m x k), rows (r x k) and out (m x r).
    unsafe {
        if beta == 0.0 {
            std::ptr::write_bytes(out, 0, m * r);
        }
        let mut c0 = 0;
        while c0 < k {
            let len = KC.min(k - c0);
            for j in 0..r {
                let bj = rows.add(j * k + c0);
                let mut i = 0;
                while i < m {
                    let at = |d: usize| a.add((i + d) * k + c0);
                    let o = out.add(i * r + j);
                    match m - i {
                        1 => dots_block::<1>(len, [at(0)], bj, o, r),
                        2 => dots_block::<2>(len, [at(0), at(1)], bj, o, r),
                        3 => dots_block::<3>(len, [at(0), at(1), at(2)], bj, o, r),
                        _ => dots_block::<4>(len, [at(0), at(1), at(2), at(3)], bj, o, r),
                    }
                    i += 4;
                }
            }
            c0 += len;
        }
    }
}

/// out[d * r] += a_d . b over `len` elements for R rows a_d (a [`dots_wide`] block).
#[target_feature(enable = "avx512f")]
#[inline(never)]
unsafe fn dots_block<const R: usize>(
    len: usize,
    a: [*const f32; R],
    b: *const f32,
    out: *mut f32,
    r: usize,
) {
    let tail = (len % 16) as u32;
    let mask: __mmask16 = ((1u32 << tail) - 1) as u16;
    let full = len - len % 16;
    // SAFETY (whole body): a_d and b hold len elements, out[d * r] lies in the result.
    unsafe {
        let mut acc = [[_mm512_setzero_ps(); 2]; R];
        let mut p = 0;
        while p + 32 <= full {
            let (b0, b1) = (load(b.add(p)), load(b.add(p + 16)));
            for d in 0..R {
                acc[d][0] = _mm512_fmadd_ps(load(a[d].add(p)), b0, acc[d][0]);
                acc[d][1] = _mm512_fmadd_ps(load(a[d].add(p + 16)), b1, acc[d][1]);
            }
            p += 32;
        }
        if p < full {
            let b0 = load(b.add(p));
            for d in 0..R {
                acc[d][0] = _mm512_fmadd_ps(load(a[d].add(p)), b0, acc[d][0]);
            }
        }
        if tail > 0 {
            let x = b.add(full);
            let b1 = _mm512_maskz_loadu_ps(mask, x);
            for d in 0..R {
                let x = a[d].add(full);
                acc[d][1] = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(mask, x), b1, acc[d][1]);
            }
        }
        for (d, acc) in acc.iter().enumerate() {
            *out.add(d * r) += _mm512_reduce_add_ps(_mm512_add_ps(acc[0], acc[1]));
        }
    }
}
