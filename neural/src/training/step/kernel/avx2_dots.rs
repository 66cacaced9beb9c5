//! The AVX2 + FMA dot-product kernels of `gemm` (x86-64, checked at run time:
//! `super::resolve`): products a b^T with b row-major, row against row, for the layers of
//! width 1 and 3 and the heads' d_out W^T (the same contract as `avx512`'s).

use super::avx2::load;
use std::arch::x86_64::*;

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
