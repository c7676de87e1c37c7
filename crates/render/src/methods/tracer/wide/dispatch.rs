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
    #[inline(always)]
    pub(crate) fn run<J: Job>(self, job: J) -> J::Output {
        match self {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => match pulp::x86::V4::try_new() {
                Some(simd) => simd.vectorize(OnSimd(job)),
                None => job.call(),
            },
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => match pulp::x86::V3::try_new() {
                Some(simd) => simd.vectorize(OnSimd(job)),
                None => job.call(),
            },
            _ => job.call(),
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

#[cfg(target_arch = "x86_64")]
struct OnSimd<J>(J);

#[cfg(target_arch = "x86_64")]
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
