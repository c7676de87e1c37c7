//! `blurlab stats`: statistical helpers: `srange-quantile` (W of David's grouping) and
//! `ceiling` (what a perfect forecast of vote tables can reach against their own noise).

mod ceiling;

use super::BadInput;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    which: Which,
}

#[derive(clap::Subcommand)]
enum Which {
    /// W_{t,alpha}: the upper alpha quantile of the range of t independent standard normals
    /// (studentized range, infinite degrees of freedom).
    SrangeQuantile {
        /// Number of stimuli (at least 2).
        #[arg(long)]
        t: usize,
        /// Upper-tail probability, strictly between 0 and 1.
        #[arg(long)]
        alpha: f64,
        /// Judges: also print R_c = (W sqrt(m t) + 1/2) / 2 and ceil(R_c).
        #[arg(long)]
        judges: Option<u32>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// What a perfect forecast of vote tables can reach: each table's totals fitted by
    /// Thurstone qualities, replicate tables drawn from them, and the Spearman correlation of
    /// the table's own order with each replicate (`analysis::ceiling`).
    Ceiling(ceiling::CeilingArgs),
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    match &args.which {
        Which::Ceiling(c) => ceiling::run(c),
        &Which::SrangeQuantile { t, alpha, judges, json } => {
            let w = analysis::srange::srange_quantile(t, alpha).map_err(|e| BadInput(e.to_string()))?;
            let critical = judges
                .map(|m| analysis::grouping::critical_range(t, m, alpha))
                .transpose()
                .map_err(|e| BadInput(e.to_string()))?;
            if json {
                let mut value = serde_json::json!({ "t": t, "alpha": alpha, "w": w });
                if let Some(c) = critical {
                    value["judges"] = c.judges.into();
                    value["rc"] = c.rc.into();
                    value["ceil_rc"] = c.ceil_rc.into();
                }
                println!("{value}");
            } else {
                println!("W(t = {t}, alpha = {alpha}) = {w:.6}");
                if let Some(c) = critical {
                    println!("m = {}: R_c = {:.4}, ceil(R_c) = {}", c.judges, c.rc, c.ceil_rc);
                }
            }
            Ok(())
        }
    }
}
