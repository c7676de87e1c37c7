//! The instruction sets the wide tracer runs on, detected at run time.

use std::fmt;

/// An instruction set a row of the wide tracer is compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Isa {
    /// AVX-512 (F, VL, BW, DQ, CD and the rest of x86-64-v4).
    Avx512,
    /// AVX2 with FMA and BMI (x86-64-v3).
    Avx2,
    /// What every CPU of the target has: SSE2 on x86-64, NEON on aarch64.
    Baseline,
}

impl Isa {
    /// The widest set this CPU has.
    pub fn widest() -> Isa {
        Isa::available()[0]
    }

    /// The sets this CPU has, widest first (the baseline always).
    pub fn available() -> Vec<Isa> {
        [Isa::Avx512, Isa::Avx2, Isa::Baseline].into_iter().filter(|i| i.is_available()).collect()
    }

    /// Whether this CPU has the set.
    pub fn is_available(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => pulp::x86::V4::is_available(),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => pulp::x86::V3::is_available(),
            #[cfg(not(target_arch = "x86_64"))]
            Isa::Avx512 | Isa::Avx2 => false,
            Isa::Baseline => true,
        }
    }

    /// The name the command line and the benchmarks use.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Avx512 => "avx512",
            Isa::Avx2 => "avx2",
            Isa::Baseline if cfg!(target_arch = "x86_64") => "sse2",
            Isa::Baseline if cfg!(target_arch = "aarch64") => "neon",
            Isa::Baseline => "baseline",
        }
    }

    /// Runs `job` compiled for this set (`job.call` and what it calls must be
    /// `#[inline(always)]` to be compiled for it); on a CPU without the set, compiled for
    /// the baseline.
    ///
    /// Each set's copy of `job` is compiled in a module of its own ([`on_avx512`],
    /// [`on_avx2`], [`on_baseline`]), so that the copies are separate codegen units that
    /// compile side by side: in one unit they made the crate's build one long serial step.
    /// The crate's unit-test harness, a second opt-level-3 build of the whole crate beside
    /// the library's, compiles the baseline copy only: no unit test chooses a set (every
    /// set gives the same bytes, which `tests/tracer_wide.rs` checks on the library as it
    /// ships).
    #[inline]
    pub(crate) fn run<J: Job>(self, job: J) -> J::Output {
        match self {
            #[cfg(all(target_arch = "x86_64", not(test)))]
            Isa::Avx512 => match pulp::x86::V4::try_new() {
                Some(simd) => on_avx512::run(simd, job),
                None => on_baseline::run(job),
            },
            #[cfg(all(target_arch = "x86_64", not(test)))]
            Isa::Avx2 => match pulp::x86::V3::try_new() {
                Some(simd) => on_avx2::run(simd, job),
                None => on_baseline::run(job),
            },
            _ => on_baseline::run(job),
        }
    }
}

/// Work compiled for an instruction set by [`Isa::run`]: its `call` must be
/// `#[inline(always)]` (a closure would be compiled once, for the baseline, and called).
pub(crate) trait Job {
    /// What it returns.
    type Output;
    /// Does the work.
    fn call(self) -> Self::Output;
}

/// A job compiled for AVX-512.
#[cfg(all(target_arch = "x86_64", not(test)))]
mod on_avx512 {
    use super::{Job, OnSimd};

    #[inline(never)]
    pub(super) fn run<J: Job>(simd: pulp::x86::V4, job: J) -> J::Output {
        simd.vectorize(OnSimd(job))
    }
}

/// A job compiled for AVX2.
#[cfg(all(target_arch = "x86_64", not(test)))]
mod on_avx2 {
    use super::{Job, OnSimd};

    #[inline(never)]
    pub(super) fn run<J: Job>(simd: pulp::x86::V3, job: J) -> J::Output {
        simd.vectorize(OnSimd(job))
    }
}

/// A job compiled for the baseline.
mod on_baseline {
    use super::Job;

    #[inline(never)]
    pub(super) fn run<J: Job>(job: J) -> J::Output {
        job.call()
    }
}

#[cfg(all(target_arch = "x86_64", not(test)))]
struct OnSimd<J>(J);

#[cfg(all(target_arch = "x86_64", not(test)))]
impl<J: Job> pulp::NullaryFnOnce for OnSimd<J> {
    type Output = J::Output;

    #[inline(always)]
    fn call(self) -> J::Output {
        self.0.call()
    }
}

impl fmt::Display for Isa {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
