//! Paired-comparison statistics, significance grouping, scaling, cost-aware equivalence,
//! reports and plots.
//!
//! Each statistic is a public function over plain counts: [`paired`] (preference matrix,
//! circular triads, consistency zeta, agreement u), [`grouping`] (David's method),
//! [`srange`] (the quantile W of the range of normals), [`factors`] (per-factor preference),
//! [`scaling`] (Thurstone Case V with bootstrap intervals), [`incomplete`] (designs in
//! which participants judge only some pairs: the scale's groups), [`screening`] (observer
//! screening, leave one participant out). [`logs`] reads and checks the
//! runner's response logs, [`experiment`] analyses one experiment (matching accuracy and
//! cost-aware equivalence included), [`report`] and [`plots`] write the report folder, and
//! [`votes`] reads published vote totals, [`forecast`] turns an image-computable
//! observer's qualities into expected votes and groups and compares them with published ones,
//! and [`ceiling`] measures what a perfect forecast reaches against a table's own noise.

pub mod ceiling;
pub mod cost;
pub mod experiment;
pub mod factors;
pub mod forecast;
pub mod grouping;
pub mod incomplete;
pub mod logs;
pub mod paired;
pub mod plots;
pub mod prediction;
pub mod rasterizer;
pub mod report;
pub mod scaling;
pub mod screening;
pub mod srange;
pub mod synthetic;
pub mod votes;
