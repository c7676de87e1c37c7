//! Paired-comparison statistics, significance grouping, scaling, cost-aware equivalence,
//! reports and plots.
//!
//! Each statistic is a public function over plain counts ([`paired`], [`grouping`],
//! [`srange`], [`scaling`]); [`votes`] reads published vote totals.

pub mod grouping;
pub mod paired;
pub mod srange;
pub mod votes;
