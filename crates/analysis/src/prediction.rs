//! Predicted against measured equivalence groups: the groups of an analysis of simulated
//! image-computable observers (`blurlab run --simulate flip`, FLIP distances of the frames)
//! beside those of participants (or of another model), experiment by experiment, so that a
//! design's groups can be predicted before anyone is tested and checked once people are.

use crate::report::Report;

/// The groups of one experiment as label lists, most preferred first.
fn groups(report: &Report, name: &str) -> Option<Vec<Vec<String>>> {
    let e = report.experiments.iter().find(|e| e.name == name)?;
    let p = e.paired.as_ref()?;
    Some(p.groups.iter().map(|g| g.members.iter().map(|m| m.label.clone()).collect()).collect())
}

/// Whether two group lists are the same sets of members in the same order.
pub fn same_groups(a: &[Vec<String>], b: &[Vec<String>]) -> bool {
    let norm = |g: &[Vec<String>]| -> Vec<Vec<String>> {
        g.iter()
            .map(|m| {
                let mut m = m.clone();
                m.sort();
                m
            })
            .collect()
    };
    norm(a) == norm(b)
}

/// A Markdown section per experiment that both reports analysed with paired comparisons:
/// group by group, the measured members beside the predicted ones, and whether they agree.
pub fn side_by_side(measured: &Report, predicted: &Report, predicted_by: &str) -> String {
    let mut md = format!("# Predicted and measured equivalence groups\n\nPredicted by: {predicted_by}.\n");
    for e in &measured.experiments {
        let (Some(m), Some(p)) = (groups(measured, &e.name), groups(predicted, &e.name)) else { continue };
        md.push_str(&format!(
            "\n## {}\n\n{}\n\n| group | measured | predicted |\n| --- | --- | --- |\n",
            e.name,
            if same_groups(&m, &p) { "The groups agree." } else { "The groups differ." }
        ));
        for k in 0..m.len().max(p.len()) {
            let cell =
                |g: &[Vec<String>]| g.get(k).map_or("-".to_owned(), |members| format!("{{{}}}", members.join(", ")));
            md.push_str(&format!("| G{} | {} | {} |\n", k + 1, cell(&m), cell(&p)));
        }
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_compare_as_sets_in_order() {
        let g = |v: &[&[&str]]| -> Vec<Vec<String>> {
            v.iter().map(|m| m.iter().map(|s| s.to_string()).collect()).collect()
        };
        assert!(same_groups(&g(&[&["A5", "A4"], &["A1"]]), &g(&[&["A4", "A5"], &["A1"]])));
        assert!(!same_groups(&g(&[&["A5", "A4"], &["A1"]]), &g(&[&["A5"], &["A4", "A1"]])));
        assert!(!same_groups(&g(&[&["A5"]]), &g(&[&["A5"], &["A1"]])));
    }
}
