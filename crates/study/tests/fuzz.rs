//! Property-based fuzzing of every parser of user files in `study`: design and experiment
//! TOML, response logs (CSV), sequence manifests and set indexes (JSON). Each gets arbitrary
//! bytes and structured mutations of a valid file (a line deleted or duplicated, a value
//! replaced by an extreme or ill-typed one, the text cut short, bytes inserted); the property
//! is that parsing returns (never panics), and that whatever parses survives a round trip
//! (serialised again and re-parsed to the same value).
//!
//! The case budget is `BLURLAB_FUZZ_CASES` per property (default 64: a few seconds in CI);
//! run longer by hand, e.g. `BLURLAB_FUZZ_CASES=20000 cargo test -p blurlab-study --test fuzz`.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use study::design::Design;
use study::experiment::ExperimentDefinition;
use study::manifest::{SequenceManifest, SetIndex};
use study::response::{COLUMNS, RESPONSES_FORMAT, SessionLog};

fn cases() -> u32 {
    std::env::var("BLURLAB_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(64)
}

fn config() -> ProptestConfig {
    ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() }
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn design_path() -> PathBuf {
    repo().join("stimuli/navarro2011.toml")
}

fn design_text() -> String {
    std::fs::read_to_string(design_path()).unwrap()
}

fn experiment_path() -> PathBuf {
    repo().join("experiments/mono-3-interactions.toml")
}

fn experiment_text() -> String {
    std::fs::read_to_string(experiment_path()).unwrap()
}

const LOG: &str = "# blurlab-responses/1
# experiment: mono-3-interactions
# experiment_sha256: 3f
# stimulus_set_sha256: 9a
# software_version: 0.1.0
# seed: 1234
# participant: P01
# session: 1
# display: {\"mode\":\"mono\"}
trial,practice,task,shown,choice,correct,response_ms,replays,dropped_frames,timestamp
0,1,2afc,M2-S2-T3-A1|M2-S2-T5-A5,M2-S2-T5-A5,,1840,0,0,2026-11-23T11:24:00.123Z
1,0,match,M2-S2-T3-A5|M2-S2-T3-A5|M2-S2-T1-A5,M2-S2-T3-A5,1,2210,1,0,2026-11-23T11:24:09.870Z
2,0,2afc,M2-S2-T3-A1-stereo|M2-S2-T5-A5-stereo,M2-S2-T3-A1-stereo,,100,0,3,2026-11-23T11:24:19.870Z
# completed: 2026-11-23T11:40:12.002Z
";

fn manifest_text() -> String {
    r#"{
  "format": "blurlab-sequence/1",
  "id": "M2-S2-T3-A5",
  "view": "mono",
  "factors": {
    "material": {"label": "M2", "name": "checker", "value": 2.0},
    "speed": {"label": "S2", "name": "slow", "value": 5.0},
    "shutter": {"label": "T3", "name": "50 %", "value": 0.5},
    "samples": {"label": "A5", "name": "512", "value": 512.0}
  },
  "method": "tracer",
  "preset": "quick",
  "width": 160,
  "height": 90,
  "fps": 30.0,
  "samples_per_pixel": 16,
  "master_seed": 2011,
  "device": "cpu: 2 threads",
  "sampling": "independent",
  "software_version": "0.1.0",
  "design_sha256": "ab",
  "frames": [
    {"index": 0, "png": "frame-0000.png", "png_sha256": "cd", "exr": "frame-0000.exr", "exr_sha256": "ef",
     "wall_seconds": 0.5, "cpu_seconds": 1.0, "nonfinite_samples": 0, "seeds": [1, 2], "gpu_seconds": 0.25}
  ]
}
"#
    .to_owned()
}

fn index_text() -> String {
    r#"{
  "format": "blurlab-set/1",
  "design": "navarro2011",
  "design_sha256": "ab",
  "preset": "quick",
  "sampling": "nested",
  "sequences": [
    {"id": "M2-S2-T3-A5", "folder": "M2-S2-T3-A5", "manifest_sha256": "01"},
    {"id": "M1-S1-T1-A1-guertin-stereo", "folder": "M1-S1-T1-A1-guertin-stereo", "manifest_sha256": "02"}
  ]
}
"#
    .to_owned()
}

/// Values that break assumptions: extremes, wrong types, empty containers.
const NASTY: &[&str] = &[
    "0",
    "-1",
    "1",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "-9223372036854775809",
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "-inf",
    "1e-320",
    "\"\"",
    "\"x\"",
    "[]",
    "[0]",
    "{}",
    "true",
    "null",
    "\"M99-S1-T1-A1\"",
    "\"M0-S0-T0-A0\"",
    "\"\u{feff}\"",
    "1.5",
];

/// A structured mutation of `text`, chosen by the numbers.
fn mutate(text: &str, op: u8, a: usize, b: usize, bytes: &[u8]) -> Vec<u8> {
    let lines: Vec<&str> = text.lines().collect();
    let n = lines.len().max(1);
    let i = a % n;
    let mut out: Vec<String> = lines.iter().map(|l| (*l).to_owned()).collect();
    match op % 7 {
        0 => {
            out.remove(i.min(out.len().saturating_sub(1)));
        }
        1 => {
            let l = out[i].clone();
            out.insert(i, l);
        }
        2 | 3 => {
            // Replace a value after `=`, `:` or `,` with a nasty one.
            let nasty = NASTY[b % NASTY.len()];
            let line = &out[i];
            if let Some(p) = line.rfind(['=', ':', ',']) {
                out[i] = format!("{}{}{nasty}", &line[..p], &line[p..=p]);
            } else {
                out[i] = nasty.to_owned();
            }
        }
        4 => {
            let joined = out.join("\n");
            let cut = b % (joined.len() + 1);
            let mut v = joined.into_bytes();
            v.truncate(cut);
            return v;
        }
        5 => {
            let joined = out.join("\n") + "\n";
            let at = b % (joined.len() + 1);
            let mut v = joined.into_bytes();
            v.splice(at..at, bytes.iter().copied());
            return v;
        }
        _ => {
            let j = (b % n).min(out.len() - 1);
            out.swap(i, j);
        }
    }
    (out.join("\n") + "\n").into_bytes()
}

fn mutation() -> impl Strategy<Value = (u8, usize, usize, Vec<u8>)> {
    (any::<u8>(), any::<usize>(), any::<usize>(), proptest::collection::vec(any::<u8>(), 0..16))
}

/// A design that parsed survives a round trip through TOML serialisation.
fn check_design(bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    let path = design_path();
    if let Ok(d) = Design::parse(&path, &text, "x") {
        let value: toml::Table = text.parse().expect("a parsed design is TOML");
        let again = Design::parse(&path, &toml::to_string(&value).unwrap(), "x").unwrap();
        // Debug text, so that a NaN the file may hold compares equal to itself.
        assert_eq!(format!("{:?}", again.spec), format!("{:?}", d.spec));
    }
}

fn check_experiment(bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    let path = experiment_path();
    if let Ok(d) = ExperimentDefinition::parse(&path, &text) {
        let value: toml::Table = text.parse().expect("a parsed definition is TOML");
        let again = ExperimentDefinition::parse(&path, &toml::to_string(&value).unwrap()).unwrap();
        let again = ExperimentDefinition { sha256: String::new(), ..again };
        let d = ExperimentDefinition { sha256: String::new(), ..d };
        assert_eq!(format!("{again:?}"), format!("{d:?}"));
    }
}

/// A log that parsed, written again from its header and rows, parses to the same.
fn check_log(bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    let path = Path::new("fuzz.csv");
    if let Ok(log) = SessionLog::parse(path, &text) {
        let mut again = format!("# {RESPONSES_FORMAT}\n");
        for (k, v) in &log.header.fields {
            again.push_str(&format!("# {k}: {v}\n"));
        }
        again.push_str(COLUMNS);
        again.push('\n');
        for (_, row) in &log.rows {
            again.push_str(&row.to_line());
            again.push('\n');
        }
        if log.completed {
            again.push_str("# completed: x\n");
        }
        let reparsed = SessionLog::parse(path, &again).unwrap();
        let rows = |l: &SessionLog| l.rows.iter().map(|(_, r)| r.clone()).collect::<Vec<_>>();
        assert_eq!(rows(&reparsed), rows(&log));
        assert_eq!(reparsed.header, log.header);
        assert_eq!(reparsed.completed, log.completed);
    }
}

fn check_manifest(bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    let path = Path::new("manifest.json");
    if let Ok(m) = SequenceManifest::parse(path, &text) {
        let again = SequenceManifest::parse(path, &serde_json::to_string(&m).unwrap()).unwrap();
        // NaN never equals itself; compare the serialised forms.
        assert_eq!(serde_json::to_string(&again).unwrap(), serde_json::to_string(&m).unwrap());
    }
}

fn check_index(bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    let path = Path::new("index.json");
    if let Ok(i) = SetIndex::parse(path, &text) {
        let again = SetIndex::parse(path, &serde_json::to_string(&i).unwrap()).unwrap();
        assert_eq!(again, i);
    }
}

#[test]
fn the_valid_files_parse_and_round_trip() {
    assert!(Design::parse(&design_path(), &design_text(), "x").is_ok());
    assert!(ExperimentDefinition::parse(&experiment_path(), &experiment_text()).is_ok());
    assert_eq!(SessionLog::parse(Path::new("l.csv"), LOG).unwrap().rows.len(), 3);
    assert!(SequenceManifest::parse(Path::new("m.json"), &manifest_text()).is_ok());
    assert_eq!(SetIndex::parse(Path::new("i.json"), &index_text()).unwrap().sequences.len(), 2);
    check_design(design_text().as_bytes());
    check_experiment(experiment_text().as_bytes());
    check_log(LOG.as_bytes());
    check_manifest(manifest_text().as_bytes());
    check_index(index_text().as_bytes());
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn design_toml(bytes in proptest::collection::vec(any::<u8>(), 0..512), (op, a, b, extra) in mutation()) {
        check_design(&bytes);
        check_design(&mutate(&design_text(), op, a, b, &extra));
    }

    #[test]
    fn experiment_toml(bytes in proptest::collection::vec(any::<u8>(), 0..512), (op, a, b, extra) in mutation()) {
        check_experiment(&bytes);
        check_experiment(&mutate(&experiment_text(), op, a, b, &extra));
    }

    #[test]
    fn response_csv(bytes in proptest::collection::vec(any::<u8>(), 0..512), (op, a, b, extra) in mutation()) {
        check_log(&bytes);
        let mut with_header = format!("# {RESPONSES_FORMAT}\n").into_bytes();
        with_header.extend_from_slice(&bytes);
        check_log(&with_header);
        check_log(&mutate(LOG, op, a, b, &extra));
    }

    #[test]
    fn manifest_json(bytes in proptest::collection::vec(any::<u8>(), 0..512), (op, a, b, extra) in mutation()) {
        check_manifest(&bytes);
        check_manifest(&mutate(&manifest_text(), op, a, b, &extra));
    }

    #[test]
    fn index_json(bytes in proptest::collection::vec(any::<u8>(), 0..512), (op, a, b, extra) in mutation()) {
        check_index(&bytes);
        check_index(&mutate(&index_text(), op, a, b, &extra));
    }
}
