//! The element-wise passes of `siren_grad` that do not ride on a product's epilogue (the
//! layer of width 1 at the top), and Adam's update. Plain loops, compiled twice more, with
//! AVX-512 and with AVX2 + FMA enabled, run on what the CPU has (`kernel::current`), so they
//! vectorise to 16 or 8 lanes. No contraction into fused multiply-adds: Rust keeps every
//! operation as written, so each version computes the plain loop's values bit for bit.

macro_rules! with_simd {
    ($(#[$doc:meta])* pub fn $name:ident($($arg:ident: $ty:ty),*) $body:block) => {
        $(#[$doc])*
        pub fn $name($($arg: $ty),*) {
            #[inline(always)]
            #[allow(clippy::too_many_arguments)]
            fn body($($arg: $ty),*) $body
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx512f")]
            #[allow(clippy::too_many_arguments)]
            fn fast($($arg: $ty),*) {
                body($($arg),*)
            }
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2,fma")]
            #[allow(clippy::too_many_arguments)]
            fn fast256($($arg: $ty),*) {
                body($($arg),*)
            }
            match super::kernel::current() {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: the CPU has AVX-512F (`kernel::resolve` checked it).
                Some(super::kernel::Isa::Avx512) => unsafe { fast($($arg),*) },
                #[cfg(target_arch = "x86_64")]
                // SAFETY: the CPU has AVX2 and FMA (`kernel::resolve` checked them).
                Some(super::kernel::Isa::Avx2) => unsafe { fast256($($arg),*) },
                _ => body($($arg),*),
            }
        }
    };
}

with_simd! {
    /// v[i, j] = w[j] and q[i, j] = w[j] c[i, j] (rows of `w.len()`).
    pub fn broadcast_times(w: &[f32], c: &[f32], v: &mut [f32], q: &mut [f32]) {
        for ((c, v), q) in c.chunks_exact(w.len()).zip(v.chunks_exact_mut(w.len())).zip(q.chunks_exact_mut(w.len())) {
            for (((c, v), q), w) in c.iter().zip(v.iter_mut()).zip(q.iter_mut()).zip(w) {
                *v = *w;
                *q = w * c;
            }
        }
    }
}

with_simd! {
    /// grad[j] += the sum over rows i of adj[i, j] + d_f[i] h[i, j] (rows of `grad.len()`).
    pub fn last_layer_grad(adj: &[f32], h: &[f32], d_f: &[f32], grad: &mut [f32]) {
        let width = grad.len();
        for ((a, h), d) in adj.chunks_exact(width).zip(h.chunks_exact(width)).zip(d_f) {
            for ((g, a), h) in grad.iter_mut().zip(a).zip(h) {
                *g += a + d * h;
            }
        }
    }
}

with_simd! {
    /// v[i, j] += d_f[i] w[j] c[i, j] (rows of `w.len()`).
    pub fn add_outer_times(d_f: &[f32], w: &[f32], c: &[f32], v: &mut [f32]) {
        for ((c, v), d) in c.chunks_exact(w.len()).zip(v.chunks_exact_mut(w.len())).zip(d_f) {
            for ((c, v), w) in c.iter().zip(v.iter_mut()).zip(w) {
                *v += d * w * c;
            }
        }
    }
}

with_simd! {
    /// Adam's update of parameters `p` from gradients `g` and moments `m`, `v` with decay
    /// rates `betas` (`first`: the moments start from this gradient, as burn's do). The same
    /// operations in the same order on every lane, so the update is the scalar one bit for bit.
    #[allow(clippy::too_many_arguments)]
    pub fn adam_update(p: &mut [f32], g: &[f32], m: &mut [f32], v: &mut [f32], betas: [f32; 2], first: bool, lr: f32, factor: f32, eps: f32) {
        let [beta1, beta2] = betas;
        for (((p, &gr), m), v) in p.iter_mut().zip(g).zip(m.iter_mut()).zip(v.iter_mut()) {
            if first {
                *m = gr * (1.0 - beta1);
                *v = gr * gr * (1.0 - beta2);
            } else {
                *m = *m * beta1 + gr * (1.0 - beta1);
                *v = *v * beta2 + gr * gr * (1.0 - beta2);
            }
            *p -= lr * (*m * factor / (v.sqrt() + eps));
        }
    }
}
