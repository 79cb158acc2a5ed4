//! Helpers shared by integration tests: reading committed reference tables.
#![allow(dead_code)]

use std::path::PathBuf;

/// Path of a file under `tests/reference/`.
pub fn reference_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("reference")
        .join(name)
}

/// A CSV reference table: header names and rows of raw strings.
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn load(name: &str) -> Self {
        let text = std::fs::read_to_string(reference_path(name))
            .unwrap_or_else(|e| panic!("reading reference {name}: {e}"));
        let mut lines = text.lines();
        let header = lines
            .next()
            .unwrap()
            .split(',')
            .map(str::to_owned)
            .collect();
        let rows = lines
            .filter(|l| !l.trim().is_empty())
            .map(|l| l.split(',').map(str::to_owned).collect())
            .collect();
        Self { header, rows }
    }

    pub fn col(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name}"))
    }

    /// Value of `name` in `row`, parsed to the nearest double.
    pub fn f64(&self, row: &[String], name: &str) -> f64 {
        row[self.col(name)].parse().unwrap()
    }

    pub fn str<'a>(&self, row: &'a [String], name: &str) -> &'a str {
        &row[self.col(name)]
    }
}

/// Writes a simulated slide of the test contact (PTFE near the paper's Fig. 2 fit: α = 0.92e6
/// 1/m, a/F_d = 0.62, F_d = 10 mN, t0 = 14.8 s, k = 1.2e4 N/m, v = 1 nm/s, σ = 0.1 mN) to
/// `dir/name`; a repeat slide follows a first slide of `first_s` seconds.
pub fn simulate_ptfe(
    dir: &std::path::Path,
    name: &str,
    scene: slipbayes::law::Scene,
    duration: f64,
    interval: f64,
    seed: u64,
    first_s: f64,
) -> PathBuf {
    use slipbayes::law::{LawParams, Scene};
    use slipbayes::simulate::{simulate, SimulationSpec};
    let spec = SimulationSpec {
        scene,
        params: LawParams::new(0.92e6, 0.62 * 10e-3, 10e-3, 14.8).unwrap(),
        stiffness_n_per_m: Some(1.2e4),
        law: Default::default(),
        rigid: false,
        velocity_m_per_s: 1e-9,
        duration_s: duration,
        interval_s: interval,
        noise_sd_n: 1e-4,
        seed,
        f_end_n: None,
        after_first_s: (scene == Scene::Repeat).then_some(first_s),
        normal_force_n: None,
        normal_noise_sd_n: 0.0,
    };
    let path = dir.join(name);
    simulate(&spec).unwrap().series.write_csv(&path).unwrap();
    path
}

/// The summary of quantity `name[group]` (a parameter or a derived value) of a fit.
#[cfg(feature = "parquet")]
pub fn stats<'a>(
    s: &'a slipbayes::fit::FitSummary,
    name: &str,
    group: &str,
) -> &'a slipbayes::diagnostics::Summary {
    &s.parameters
        .iter()
        .chain(&s.derived)
        .find(|q| q.name == name && q.group == group)
        .unwrap_or_else(|| panic!("no {name}[{group}]"))
        .stats
}

/// Every parameter of the fit has R̂ below 1.05.
#[cfg(feature = "parquet")]
pub fn assert_r_hat_below_1_05(s: &slipbayes::fit::FitSummary) {
    for q in &s.parameters {
        let r_hat = q.stats.r_hat.unwrap_or(f64::NAN);
        assert!(r_hat < 1.05, "{}[{}]: R̂ {r_hat}", q.name, q.group);
    }
}

/// The fit's 95 % interval of each quantity `(name, group, truth)` holds its truth.
#[cfg(feature = "parquet")]
pub fn assert_covers(s: &slipbayes::fit::FitSummary, truths: &[(&str, &str, f64)]) {
    for &(name, group, truth) in truths {
        let st = stats(s, name, group);
        assert!(
            st.ci_low <= truth && truth <= st.ci_high,
            "{name}[{group}]: truth {truth:e} outside [{:e}, {:e}]",
            st.ci_low,
            st.ci_high
        );
    }
}
