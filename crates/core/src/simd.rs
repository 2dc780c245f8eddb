//! Run-time choice between the baseline build of the hot loops and a clone compiled for AVX2 and
//! FMA.
//!
//! Why: the release binary targets baseline x86-64 (SSE2) so that it runs on every x86-64 CPU,
//! yet building the whole crate with `-C target-cpu=x86-64-v3` gave bit-identical frames and
//! saved 15–23 % of the render's CPU time (docs/BENCHMARKS.md, "Runtime AVX2 dispatch"). The two
//! hot loops are therefore compiled twice, function-multiversioning style, and the clone is
//! picked at run time:
//!
//! * the ray tracer's band of tiles (`Renderer::render` of scene-gen-render, in its `tile.rs`);
//! * the evaluator's fused sensor row (`isp::capture_8bit` of scene-gen-camera).
//!
//! Each has a generic body marked `#[inline(always)]`, an `unsafe fn ..._avx2` with
//! `#[target_feature(enable = "avx2,fma")]` that only calls that body (so LLVM compiles the body,
//! and everything inlined into it, with VEX-encoded AVX2 instructions), and a safe dispatcher
//! that calls the clone only when [`Dispatch::supported`] says the CPU can run it.
//!
//! Why the output bytes do not change: Rust never contracts `a * b + c` into a fused
//! multiply-add (only an explicit `mul_add` fuses, and that is exact in both builds), LLVM does
//! not reassociate floating-point sums without fast-math flags, and the library calls (`exp`,
//! `ln`, `powf`, ...) are the same functions in both clones. `cfg(target_feature = ..)` code in
//! dependencies (glam, obvhs) is chosen at compile time for the whole crate, so both clones
//! take the same branches. Tests in `render` and `isp` compare the two paths byte for byte.
//!
//! Set the environment variable `SCENE_GEN_NO_SIMD=1` to force the baseline path (for
//! benchmarks, or to rule the clone out when chasing a bug); it is read once per process.
//! On targets other than x86-64 only the baseline path exists.

use std::sync::OnceLock;

/// Environment variable that forces [`Dispatch::Generic`] when set to anything but empty or `0`.
pub const NO_SIMD_ENV: &str = "SCENE_GEN_NO_SIMD";

/// Which build of a hot loop runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Dispatch {
    /// The baseline code of the target (SSE2 on x86-64): runs on every CPU.
    Generic,
    /// The same source compiled with AVX2 and FMA enabled (x86-64 only; Haswell, Zen and later).
    Avx2Fma,
}

impl Dispatch {
    /// What the hot loops use in this process: [`Dispatch::best`] unless [`NO_SIMD_ENV`] is set.
    /// Decided at the first call and cached, so a frame never mixes the two.
    #[must_use]
    pub fn current() -> Dispatch {
        static CURRENT: OnceLock<Dispatch> = OnceLock::new();
        *CURRENT.get_or_init(|| {
            if forces_generic(std::env::var_os(NO_SIMD_ENV).as_deref()) { Dispatch::Generic } else { Dispatch::best() }
        })
    }

    /// The fastest build this CPU can run, whatever the environment says (detected once).
    #[must_use]
    pub fn best() -> Dispatch {
        static BEST: OnceLock<Dispatch> = OnceLock::new();
        *BEST.get_or_init(|| if avx2_fma_detected() { Dispatch::Avx2Fma } else { Dispatch::Generic })
    }

    /// `self` where this CPU can run it, else [`Dispatch::Generic`]: what a dispatcher runs when
    /// asked for `self`. Only a `supported()` value of [`Dispatch::Avx2Fma`] may reach an
    /// `unsafe fn ..._avx2`.
    #[must_use]
    pub fn supported(self) -> Dispatch {
        match self {
            Dispatch::Avx2Fma if Dispatch::best() == Dispatch::Avx2Fma => Dispatch::Avx2Fma,
            _ => Dispatch::Generic,
        }
    }
}

/// Whether the value of [`NO_SIMD_ENV`] asks for the baseline path.
fn forces_generic(value: Option<&std::ffi::OsStr>) -> bool {
    value.is_some_and(|v| !v.is_empty() && v != "0")
}

#[cfg(target_arch = "x86_64")]
fn avx2_fma_detected() -> bool {
    std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
}

#[cfg(not(target_arch = "x86_64"))]
fn avx2_fma_detected() -> bool {
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_set_nonzero_variable_forces_the_baseline() {
        assert!(!forces_generic(None));
        assert!(!forces_generic(Some("".as_ref())));
        assert!(!forces_generic(Some("0".as_ref())));
        assert!(forces_generic(Some("1".as_ref())));
        assert!(forces_generic(Some("yes".as_ref())));
    }

    #[test]
    fn supported_never_exceeds_the_cpu() {
        assert_eq!(Dispatch::Generic.supported(), Dispatch::Generic);
        assert_eq!(Dispatch::Avx2Fma.supported(), Dispatch::best());
        assert_eq!(Dispatch::current().supported(), Dispatch::current());
        #[cfg(not(target_arch = "x86_64"))]
        assert_eq!(Dispatch::best(), Dispatch::Generic);
    }
}
