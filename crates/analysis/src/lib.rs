//! Paired-comparison statistics, significance grouping, scaling, cost-aware equivalence, reports and plots.
