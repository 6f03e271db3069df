//! Eight-lane vector operations for the Poisson kernels.
//!
//! [`Portable`] is plain Rust on arrays; [`Avx2`] (x86-64) uses AVX intrinsics and can only be obtained on a CPU
//! that has AVX2 ([`Avx2::detect`]), which is what makes its safe methods sound. Both perform the same IEEE-754
//! operations lane by lane, in the same order, with no fused multiply-add, and round f64 → f32 to nearest, so the
//! solver gives bit-identical results on either path (a test checks it).
//!
//! The kernels are written once, generic over [`Simd`], and marked `#[inline(always)]`; the AVX2 instantiation is
//! entered through a `#[target_feature(enable = "avx2")]` function, so everything inlines into AVX2 code.

/// Lanes per vector.
pub const LANES: usize = 8;

/// Eight f32 or f64 lanes and the operations the kernels need. The loads and stores take `LANES` elements from
/// index `i` and are unchecked: the kernels slice each operand once per segment and guarantee `i + LANES <= len`.
pub trait Simd: Copy {
    /// Eight f32.
    type V32: Copy;
    /// Eight f64.
    type V64: Copy;

    /// The `LANES` elements of `s` from `i`.
    ///
    /// # Safety
    /// `i + LANES <= s.len()`.
    unsafe fn ld32u(self, s: &[f32], i: usize) -> Self::V32;
    /// Stores `v` into the `LANES` elements of `s` from `i`.
    ///
    /// # Safety
    /// `i + LANES <= s.len()`.
    unsafe fn st32u(self, s: &mut [f32], i: usize, v: Self::V32);
    fn add32(self, a: Self::V32, b: Self::V32) -> Self::V32;
    fn sub32(self, a: Self::V32, b: Self::V32) -> Self::V32;
    fn mul32(self, a: Self::V32, b: Self::V32) -> Self::V32;
    fn splat32(self, x: f32) -> Self::V32;

    /// As [`Simd::ld32u`], for f64.
    ///
    /// # Safety
    /// `i + LANES <= s.len()`.
    unsafe fn ld64u(self, s: &[f64], i: usize) -> Self::V64;
    /// As [`Simd::st32u`], for f64.
    ///
    /// # Safety
    /// `i + LANES <= s.len()`.
    unsafe fn st64u(self, s: &mut [f64], i: usize, v: Self::V64);
    fn add64(self, a: Self::V64, b: Self::V64) -> Self::V64;
    fn sub64(self, a: Self::V64, b: Self::V64) -> Self::V64;
    fn mul64(self, a: Self::V64, b: Self::V64) -> Self::V64;
    fn splat64(self, x: f64) -> Self::V64;
    fn zero64(self) -> Self::V64;
    fn lanes64(self, v: Self::V64) -> [f64; LANES];

    /// f32 → f64 (exact).
    fn widen(self, v: Self::V32) -> Self::V64;
    /// f64 → f32, rounded to nearest (as `as f32`).
    fn narrow(self, v: Self::V64) -> Self::V32;
}

/// Plain Rust, any CPU.
#[derive(Debug, Clone, Copy)]
pub struct Portable;

macro_rules! lanewise {
    ($a:expr, $b:expr, $op:tt) => {{
        let (a, b) = ($a, $b);
        let mut out = a;
        for j in 0..LANES {
            out[j] = a[j] $op b[j];
        }
        out
    }};
}

impl Simd for Portable {
    type V32 = [f32; LANES];
    type V64 = [f64; LANES];

    #[inline(always)]
    unsafe fn ld32u(self, s: &[f32], i: usize) -> [f32; LANES] {
        debug_assert!(i + LANES <= s.len(), "simd access out of bounds");
        // SAFETY: the caller guarantees i + LANES <= s.len().
        unsafe { *(s.as_ptr().add(i) as *const [f32; LANES]) }
    }
    #[inline(always)]
    unsafe fn st32u(self, s: &mut [f32], i: usize, v: [f32; LANES]) {
        debug_assert!(i + LANES <= s.len(), "simd access out of bounds");
        // SAFETY: as for ld32u.
        unsafe { *(s.as_mut_ptr().add(i) as *mut [f32; LANES]) = v }
    }
    #[inline(always)]
    fn add32(self, a: [f32; LANES], b: [f32; LANES]) -> [f32; LANES] {
        lanewise!(a, b, +)
    }
    #[inline(always)]
    fn sub32(self, a: [f32; LANES], b: [f32; LANES]) -> [f32; LANES] {
        lanewise!(a, b, -)
    }
    #[inline(always)]
    fn mul32(self, a: [f32; LANES], b: [f32; LANES]) -> [f32; LANES] {
        lanewise!(a, b, *)
    }
    #[inline(always)]
    fn splat32(self, x: f32) -> [f32; LANES] {
        [x; LANES]
    }

    #[inline(always)]
    unsafe fn ld64u(self, s: &[f64], i: usize) -> [f64; LANES] {
        debug_assert!(i + LANES <= s.len(), "simd access out of bounds");
        // SAFETY: the caller guarantees i + LANES <= s.len().
        unsafe { *(s.as_ptr().add(i) as *const [f64; LANES]) }
    }
    #[inline(always)]
    unsafe fn st64u(self, s: &mut [f64], i: usize, v: [f64; LANES]) {
        debug_assert!(i + LANES <= s.len(), "simd access out of bounds");
        // SAFETY: as for ld64u.
        unsafe { *(s.as_mut_ptr().add(i) as *mut [f64; LANES]) = v }
    }
    #[inline(always)]
    fn add64(self, a: [f64; LANES], b: [f64; LANES]) -> [f64; LANES] {
        lanewise!(a, b, +)
    }
    #[inline(always)]
    fn sub64(self, a: [f64; LANES], b: [f64; LANES]) -> [f64; LANES] {
        lanewise!(a, b, -)
    }
    #[inline(always)]
    fn mul64(self, a: [f64; LANES], b: [f64; LANES]) -> [f64; LANES] {
        lanewise!(a, b, *)
    }
    #[inline(always)]
    fn splat64(self, x: f64) -> [f64; LANES] {
        [x; LANES]
    }
    #[inline(always)]
    fn zero64(self) -> [f64; LANES] {
        [0.0; LANES]
    }
    #[inline(always)]
    fn lanes64(self, v: [f64; LANES]) -> [f64; LANES] {
        v
    }

    #[inline(always)]
    fn widen(self, v: [f32; LANES]) -> [f64; LANES] {
        let mut out = [0.0f64; LANES];
        for j in 0..LANES {
            out[j] = v[j] as f64;
        }
        out
    }
    #[inline(always)]
    fn narrow(self, v: [f64; LANES]) -> [f32; LANES] {
        let mut out = [0.0f32; LANES];
        for j in 0..LANES {
            out[j] = v[j] as f32;
        }
        out
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx2::Avx2;

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Simd, LANES};
    use std::arch::x86_64::*;

    /// AVX2 on x86-64: a token that exists only on CPUs with AVX2.
    #[derive(Debug, Clone, Copy)]
    pub struct Avx2(());

    impl Avx2 {
        /// The token, if the CPU supports AVX2 (checked once).
        pub fn detect() -> Option<Avx2> {
            use std::sync::OnceLock;
            static HAS: OnceLock<bool> = OnceLock::new();
            HAS.get_or_init(|| std::arch::is_x86_feature_detected!("avx2"))
                .then_some(Avx2(()))
        }
    }

    // SAFETY (every method): an `Avx2` value exists only if the CPU supports AVX2 (`detect`), and the loads and
    // stores stay inside `s` by the caller's guarantee `i + LANES <= s.len()`.
    impl Simd for Avx2 {
        type V32 = __m256;
        type V64 = (__m256d, __m256d);

        #[inline(always)]
        unsafe fn ld32u(self, s: &[f32], i: usize) -> __m256 {
            debug_assert!(i + LANES <= s.len(), "simd access out of bounds");
            unsafe { _mm256_loadu_ps(s.as_ptr().add(i)) }
        }
        #[inline(always)]
        unsafe fn st32u(self, s: &mut [f32], i: usize, v: __m256) {
            debug_assert!(i + LANES <= s.len(), "simd access out of bounds");
            unsafe { _mm256_storeu_ps(s.as_mut_ptr().add(i), v) }
        }
        #[inline(always)]
        fn add32(self, a: __m256, b: __m256) -> __m256 {
            unsafe { _mm256_add_ps(a, b) }
        }
        #[inline(always)]
        fn sub32(self, a: __m256, b: __m256) -> __m256 {
            unsafe { _mm256_sub_ps(a, b) }
        }
        #[inline(always)]
        fn mul32(self, a: __m256, b: __m256) -> __m256 {
            unsafe { _mm256_mul_ps(a, b) }
        }
        #[inline(always)]
        fn splat32(self, x: f32) -> __m256 {
            unsafe { _mm256_set1_ps(x) }
        }

        #[inline(always)]
        unsafe fn ld64u(self, s: &[f64], i: usize) -> (__m256d, __m256d) {
            debug_assert!(i + LANES <= s.len(), "simd access out of bounds");
            unsafe {
                let p = s.as_ptr().add(i);
                (_mm256_loadu_pd(p), _mm256_loadu_pd(p.add(4)))
            }
        }
        #[inline(always)]
        unsafe fn st64u(self, s: &mut [f64], i: usize, v: (__m256d, __m256d)) {
            debug_assert!(i + LANES <= s.len(), "simd access out of bounds");
            unsafe {
                let p = s.as_mut_ptr().add(i);
                _mm256_storeu_pd(p, v.0);
                _mm256_storeu_pd(p.add(4), v.1);
            }
        }
        #[inline(always)]
        fn add64(self, a: (__m256d, __m256d), b: (__m256d, __m256d)) -> (__m256d, __m256d) {
            unsafe { (_mm256_add_pd(a.0, b.0), _mm256_add_pd(a.1, b.1)) }
        }
        #[inline(always)]
        fn sub64(self, a: (__m256d, __m256d), b: (__m256d, __m256d)) -> (__m256d, __m256d) {
            unsafe { (_mm256_sub_pd(a.0, b.0), _mm256_sub_pd(a.1, b.1)) }
        }
        #[inline(always)]
        fn mul64(self, a: (__m256d, __m256d), b: (__m256d, __m256d)) -> (__m256d, __m256d) {
            unsafe { (_mm256_mul_pd(a.0, b.0), _mm256_mul_pd(a.1, b.1)) }
        }
        #[inline(always)]
        fn splat64(self, x: f64) -> (__m256d, __m256d) {
            unsafe { (_mm256_set1_pd(x), _mm256_set1_pd(x)) }
        }
        #[inline(always)]
        fn zero64(self) -> (__m256d, __m256d) {
            unsafe { (_mm256_setzero_pd(), _mm256_setzero_pd()) }
        }
        #[inline(always)]
        fn lanes64(self, v: (__m256d, __m256d)) -> [f64; LANES] {
            let mut out = [0.0f64; LANES];
            // SAFETY: out has LANES elements.
            unsafe { self.st64u(&mut out, 0, v) };
            out
        }

        #[inline(always)]
        fn widen(self, v: __m256) -> (__m256d, __m256d) {
            unsafe {
                (
                    _mm256_cvtps_pd(_mm256_castps256_ps128(v)),
                    _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(v)),
                )
            }
        }
        #[inline(always)]
        fn narrow(self, v: (__m256d, __m256d)) -> __m256 {
            // cvtpd_ps rounds by MXCSR, which Rust leaves at round-to-nearest-even (the rounding of `as f32`).
            unsafe { _mm256_set_m128(_mm256_cvtpd_ps(v.1), _mm256_cvtpd_ps(v.0)) }
        }
    }
}
