//! The true values behind synthetic data: `slipbayes simulate` writes them as JSON beside each
//! data file, and a fit copies them into its run directory (`truth.json`). A report overlays
//! them where every value a figure needs is known.

use super::plots::RunView;
use crate::fit::run_dir::RunTruth;
use crate::law::Scene;
use crate::model::spec::{ForwardModel, Param};
use crate::simulate::SimulationSpec;

/// The simulation settings of each run of a model whose data file has a truth file beside it.
#[derive(Debug, Clone)]
pub(crate) struct Truths {
    /// Per run: its name, contact, material, scene and, when found, what simulated it.
    runs: Vec<(String, String, String, Scene, Option<SimulationSpec>)>,
    /// The names of the truth files, beside the data files they describe.
    pub files: Vec<String>,
}

impl Truths {
    /// The true values of the runs `runs` of a model, from what the fit recorded in
    /// `truth.json`; a run without an entry has no true values.
    pub fn new(runs: &[RunView], recorded: &[RunTruth]) -> Self {
        let runs = runs
            .iter()
            .map(|r| {
                let truth = recorded.iter().find(|t| t.run == r.name);
                (
                    r.name.clone(),
                    r.contact.clone(),
                    r.material.clone(),
                    r.scene,
                    truth.map(|t| t.simulation.clone()),
                )
            })
            .collect();
        let files = recorded.iter().map(|t| t.file.clone()).collect();
        Self { runs, files }
    }

    /// The true value (SI) of the quantity `name` of `group` (a material, contact or run):
    /// known when every run of the group that uses the parameter has a truth file and they
    /// all agree. `None` otherwise, and for quantities simulations do not set (population
    /// parameters, derived quantities).
    pub fn of(&self, name: &str, group: &str) -> Option<f64> {
        let (param, value): (Param, fn(&SimulationSpec) -> Option<f64>) = match name {
            "alpha" => (Param::Alpha, |s| Some(s.params.alpha_per_m)),
            "a" => (Param::A, |s| Some(s.params.a_n)),
            "a_over_F_d" => (Param::A, |s| Some(s.params.a_n / s.params.f_d_n)),
            "F_d" => (Param::FD, |s| Some(s.params.f_d_n)),
            "t0" => (Param::T0, |s| Some(s.params.t0_s)),
            "k" => (Param::K, |s| s.stiffness_n_per_m),
            "sigma" => (Param::Sigma, |s| Some(s.noise_sd_n)),
            _ => return None,
        };
        let mut found: Option<f64> = None;
        // A run's truth holds the parameters of the model it was simulated by (which need not
        // be the model fitted); one a simulation did not set (α = 0 and F_d = 0 under pure
        // logarithmic aging) is no truth.
        for (run, contact, material, scene, truth) in &self.runs {
            if !(run == group || contact == group || material == group) {
                continue;
            }
            let truth = truth.as_ref()?;
            let simulated_by = ForwardModel {
                law: truth.law,
                elastic: !truth.rigid,
                ..ForwardModel::default()
            };
            if !simulated_by.uses(param, *scene, false) {
                continue;
            }
            let v = value(truth).filter(|v| v.is_finite() && *v > 0.0)?;
            match found {
                Some(f) if (f - v).abs() > 1e-9 * f.abs().max(v.abs()) => return None,
                _ => found = Some(v),
            }
        }
        found
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truths(runs: Vec<(&str, &str, &str, Scene, Option<SimulationSpec>)>) -> Truths {
        Truths {
            runs: runs
                .into_iter()
                .map(|(a, b, c, s, t)| (a.into(), b.into(), c.into(), s, t))
                .collect(),
            files: Vec::new(),
        }
    }

    fn sim(scene: Scene, a_n: f64, k: Option<f64>) -> SimulationSpec {
        SimulationSpec {
            scene,
            params: crate::law::LawParams::new(0.92e6, a_n, 10e-3, 14.8).unwrap(),
            stiffness_n_per_m: k,
            law: Default::default(),
            rigid: false,
            velocity_m_per_s: 1e-9,
            duration_s: 100.0,
            interval_s: 1.0,
            noise_sd_n: 1e-4,
            seed: 1,
            f_end_n: None,
            after_first_s: None,
            normal_force_n: None,
            normal_noise_sd_n: 0.0,
        }
    }

    #[test]
    fn truths_are_found_where_every_run_agrees() {
        let t = truths(vec![
            (
                "c1-first",
                "c1",
                "PTFE",
                Scene::First,
                Some(sim(Scene::First, 6e-3, Some(1e4))),
            ),
            (
                "c1-fast",
                "c1",
                "PTFE",
                Scene::StiffFast,
                Some(sim(Scene::StiffFast, 6e-3, None)),
            ),
            (
                "c2-first",
                "c2",
                "PTFE",
                Scene::First,
                Some(sim(Scene::First, 7e-3, Some(2e4))),
            ),
        ]);
        assert_eq!(t.of("alpha", "PTFE"), Some(0.92e6));
        // k is not used by the stiff fast slide, whose file has none.
        assert_eq!(t.of("k", "c1"), Some(1e4));
        // The contacts disagree on a: no single true value for the material.
        assert_eq!(t.of("a", "PTFE"), None);
        assert_eq!(t.of("a", "c2"), Some(7e-3));
        assert!((t.of("a_over_F_d", "c1").unwrap() - 0.6).abs() < 1e-12);
        assert_eq!(t.of("t0_pop_median", "PTFE"), None);
        assert_eq!(t.of("alpha", "nobody"), None);
    }

    #[test]
    fn a_run_without_a_truth_file_hides_its_groups_truth() {
        let t = truths(vec![
            (
                "c1-first",
                "c1",
                "PTFE",
                Scene::First,
                Some(sim(Scene::First, 6e-3, Some(1e4))),
            ),
            ("c2-first", "c2", "PTFE", Scene::First, None),
        ]);
        assert_eq!(t.of("alpha", "PTFE"), None);
        assert_eq!(t.of("alpha", "c1"), Some(0.92e6));
    }
}
