//! The trial list of a session: practice trials first (in the definition's order, flagged),
//! then every unordered pair of the experiment's stimuli `repeats` times, shuffled.
//!
//! With `selection = "asap"` or `"random"` [`build`] gives the practice trials only, and each
//! counted trial is chosen by [`select`] when it is due: ASAP's best pair under the shared
//! posterior (`selection::best_pair` with the paper's selective evaluation and the refined
//! search), or a uniformly random pair. Its draws (selective evaluation, ties, random pair,
//! then the order within the pair) come from a PCG-64 generator seeded with
//! `study::seed::mix(seed, [SELECTION_STREAM, trial index])`.
//!
//! Every random choice comes from one PCG-64 generator seeded with
//! `study::seed::mix(seed, [SCHEDULE_STREAM])`, where `seed` is recorded in the session's log
//! header; the same definition and seed give the same schedule, which is how a resumed
//! session continues in the same order. The order of the draws is part of the log format:
//! (1) for each practice trial, one draw for the order within the pair when shuffling is on;
//! (2) the pair list (i < j in sorted stimulus order, repeated) is shuffled with Fisher-Yates
//! when `pair_order` is on; (3) for each pair in its final order, matching draws the
//! reference (one of the two) and then, with `within_pair`, the candidate order; 2AFC draws
//! the order within the pair.

use rand::SeedableRng;
use rand_pcg::Pcg64;
use study::StimulusId;
use study::experiment::{ExperimentDefinition, PairSelection};
use study::response::Task;

/// The stream constant mixed into the session seed for the schedule.
pub const SCHEDULE_STREAM: u64 = 0x5C4E_D01E;

/// One trial of a session.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Trial {
    /// Index in the session (the `trial` column), practice trials included.
    pub index: u32,
    /// A practice trial (logged, never analysed).
    pub practice: bool,
    /// 2AFC or matching.
    pub task: Task,
    /// 2AFC: the two stimuli in the order played. Matching: the reference, then the left
    /// and right candidates (one of which is the reference).
    pub shown: Vec<StimulusId>,
}

impl Trial {
    /// The stimuli the participant chooses between, in slot order (first/left, second/right).
    pub fn options(&self) -> &[StimulusId] {
        match self.task {
            Task::TwoAfc => &self.shown,
            Task::Match => &self.shown[1..],
        }
    }

    /// The reference of a matching trial.
    pub fn reference(&self) -> Option<StimulusId> {
        (self.task == Task::Match).then(|| self.shown[0])
    }
}

/// The stream constant mixed into the session seed for a selected trial.
pub const SELECTION_STREAM: u64 = 0xA5A9_5E1E;

/// The counted trial `index` of a session with a budgeted selection: ASAP's choice under
/// `posterior` (required for `asap`) among the pairs other than `avoid`, or a random pair.
pub fn select(
    definition: &ExperimentDefinition,
    seed: u64,
    index: u32,
    posterior: Option<&selection::Posterior>,
    avoid: &[(usize, usize)],
) -> Option<Trial> {
    let mut rng = Pcg64::seed_from_u64(study::seed::mix(seed, &[SELECTION_STREAM, u64::from(index)]));
    let n = definition.stimuli.len();
    let (i, j) = match (definition.selection, posterior) {
        (PairSelection::Asap { .. }, Some(p)) => selection::best_pair_avoiding(
            p,
            selection::Evaluation::Selective,
            selection::Search::Refine(selection::REFINED_PAIRS),
            avoid,
            &mut rng,
        )?,
        (PairSelection::Random { .. }, _) if n >= 2 => selection::random_pair(n, &mut rng),
        _ => return None,
    };
    let mut pair = [definition.stimuli[i], definition.stimuli[j]];
    if definition.shuffle_within_pair && crate::index_below(&mut rng, 2) == 1 {
        pair.swap(0, 1);
    }
    Some(Trial { index, practice: false, task: definition.task, shown: pair.to_vec() })
}

/// Builds the schedule of a session (its practice trials only, for a budgeted selection).
pub fn build(definition: &ExperimentDefinition, seed: u64) -> Vec<Trial> {
    let mut rng = Pcg64::seed_from_u64(study::seed::mix(seed, &[SCHEDULE_STREAM]));
    let task = definition.task;
    let mut trials = Vec::new();
    let push = |practice: bool, shown: Vec<StimulusId>, trials: &mut Vec<Trial>| {
        let index = trials.len() as u32;
        trials.push(Trial { index, practice, task, shown });
    };
    for p in &definition.practice {
        let mut pair = p.pair;
        let reference = p.reference.unwrap_or(p.pair[0]);
        if definition.shuffle_within_pair && crate::index_below(&mut rng, 2) == 1 {
            pair.swap(0, 1);
        }
        let shown = match task {
            Task::TwoAfc => pair.to_vec(),
            Task::Match => vec![reference, pair[0], pair[1]],
        };
        push(true, shown, &mut trials);
    }
    if !definition.selection.is_complete() {
        return trials;
    }
    let s = &definition.stimuli;
    let mut pairs = Vec::new();
    for _ in 0..definition.repeats {
        for i in 0..s.len() {
            for j in i + 1..s.len() {
                pairs.push([s[i], s[j]]);
            }
        }
    }
    if definition.shuffle_pairs {
        crate::shuffle(&mut pairs, &mut rng);
    }
    for mut pair in pairs {
        let shown = match task {
            Task::TwoAfc => {
                if definition.shuffle_within_pair && crate::index_below(&mut rng, 2) == 1 {
                    pair.swap(0, 1);
                }
                pair.to_vec()
            }
            Task::Match => {
                let reference = pair[crate::index_below(&mut rng, 2)];
                if definition.shuffle_within_pair && crate::index_below(&mut rng, 2) == 1 {
                    pair.swap(0, 1);
                }
                vec![reference, pair[0], pair[1]]
            }
        };
        push(false, shown, &mut trials);
    }
    trials
}

#[cfg(test)]
pub(crate) mod tests {
    use std::collections::BTreeMap;
    use std::path::Path;

    use study::testing::{ExperimentToml, pair};

    use super::*;

    pub(crate) fn definition(task: &str, repeats: u32) -> ExperimentDefinition {
        let text = ExperimentToml {
            task: task.into(),
            question: "q".into(),
            shutter: vec![1, 2, 3, 4, 5],
            samples: vec![5],
            repeats: Some(repeats),
            practice: vec![pair("M2-S2-T1-A1", "M2-S2-T5-A5")],
            ..ExperimentToml::minimal()
        }
        .to_string();
        ExperimentDefinition::parse(Path::new("t.toml"), &text).unwrap()
    }

    #[test]
    fn all_pairs_k_times_practice_first_and_reproducible() {
        let d = definition("2afc", 2);
        let a = build(&d, 42);
        assert_eq!(a.len(), 1 + 20);
        assert!(a[0].practice && a[1..].iter().all(|t| !t.practice));
        assert!(a.iter().enumerate().all(|(i, t)| t.index as usize == i));
        let mut counts: BTreeMap<(StimulusId, StimulusId), u32> = BTreeMap::new();
        for t in &a[1..] {
            let (x, y) = (t.shown[0].min(t.shown[1]), t.shown[0].max(t.shown[1]));
            *counts.entry((x, y)).or_default() += 1;
        }
        assert_eq!(counts.len(), 10);
        assert!(counts.values().all(|&c| c == 2));
        assert_eq!(a, build(&d, 42));
        assert_ne!(a, build(&d, 43));
        // Order within pairs is randomised: both orders occur.
        assert!(a[1..].iter().any(|t| t.shown[0] < t.shown[1]) && a[1..].iter().any(|t| t.shown[0] > t.shown[1]));
    }

    #[test]
    fn matching_reference_is_one_of_the_candidates() {
        let d = definition("match", 1);
        let s = build(&d, 7);
        assert_eq!(s.len(), 11);
        for t in &s {
            assert_eq!(t.shown.len(), 3);
            assert!(t.options().contains(&t.reference().unwrap()));
            assert_ne!(t.options()[0], t.options()[1]);
        }
        assert_eq!(s[0].reference().unwrap().to_string(), "M2-S2-T1-A1");
        // Both slots hold the reference sometimes.
        assert!(s.iter().any(|t| t.shown[0] == t.shown[1]) && s.iter().any(|t| t.shown[0] == t.shown[2]));
    }

    #[test]
    fn without_shuffling_pairs_keep_sorted_order() {
        let mut d = definition("2afc", 1);
        d.shuffle_pairs = false;
        d.shuffle_within_pair = false;
        let s = build(&d, 1);
        assert_eq!(s[1].shown, vec![d.stimuli[0], d.stimuli[1]]);
        assert_eq!(s[10].shown, vec![d.stimuli[3], d.stimuli[4]]);
    }
}
