//! The joint posterior of a model over all its runs, as a [`LogDensity`] for the sampler.
//!
//! Layout: every positive parameter θ is sampled as u = ln θ (the prior's density carries the
//! Jacobian, see [`Prior`]); a pooled ln t0 is non-centred, ln t0_run = μ_m + s_m z_run with
//! z_run ~ Normal(0, 1), which keeps the ensemble out of the funnel between s_m and the t0s.
//! The sampler's coordinates are named `ln_<name>[<group>]` (`z_t0[<run>]`), and every
//! reported quantity is written, in SI units, into a derived column `<name>[<group>]`.
//!
//! Likelihood: independent Gaussian noise of standard deviation σ_run on each run's force.
//! A repeat slide loads elastically up to F_end, the force where the slide it follows stopped
//! (its model force at its last recorded time), or F_d when it follows none.

use std::path::PathBuf;

use super::data::RunData;
use super::prior::Prior;
use super::spec::{Aging, Level, ModelSpec, Param};
use crate::law::{Elastic, Law, LawError, ObservedSlide, RepeatSlide, Scene};
use crate::sampler::{LogDensity, LogDensityError};

/// Log of √(2π).
const LN_SQRT_2PI: f64 = 0.918_938_533_204_672_8;

/// Rejection labels counted by the sampler.
pub const REJECT_STICK_SLIP: &str = "stick_slip";
/// A parameter outside its prior's support.
pub const REJECT_PRIOR: &str = "outside_prior";
/// The law could not be evaluated at these parameters (e.g. αv·t0 underflows).
pub const REJECT_LAW: &str = "law_invalid";

/// Whether a reported quantity is a model parameter or derived from them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// A parameter (or hyper-parameter) of the model.
    Parameter,
    /// A function of the parameters (peak, slip distance, ...).
    Derived,
}

/// One derived column: what it reports.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Column {
    /// Column name `<name>[<group>]`.
    pub column: String,
    /// Quantity name (`alpha`, `F_peak`, ...).
    pub name: String,
    /// Material, contact or run it belongs to.
    pub group: String,
    /// SI unit.
    pub unit: String,
    /// Parameter or derived.
    pub kind: Kind,
}

/// How a sampled coordinate enters the prior.
#[derive(Debug, Clone)]
enum CoordPrior {
    /// u = ln θ with a prior on θ.
    Log(Prior),
    /// z ~ Normal(0, 1).
    StdNormal,
}

/// One sampled coordinate.
#[derive(Debug, Clone)]
struct Coord {
    name: String,
    prior: CoordPrior,
}

/// Where a run's t0 comes from.
#[derive(Debug, Clone, Copy)]
enum T0Source {
    Direct(usize),
    /// ln t0 = x[mu] + exp(x[ln_s]) x[z].
    Pooled { mu: usize, ln_s: usize, z: usize },
}

/// A run with its data and the coordinates of its parameters.
#[derive(Debug, Clone)]
struct RunModel {
    name: String,
    scene: Scene,
    velocity: f64,
    data: RunData,
    contact: usize,
    alpha: Option<usize>,
    /// Coordinate of a (or of a/F_d when `ratio`).
    a: Option<usize>,
    ratio: bool,
    f_d: usize,
    t0: Option<T0Source>,
    k: Option<usize>,
    sigma: usize,
    follows: Option<usize>,
    normal_force: Option<f64>,
}

/// Pooled t0 of one material.
#[derive(Debug, Clone, Copy)]
struct Population {
    material: usize,
    mu: usize,
    ln_s: usize,
}

/// The posterior of a validated model with its data loaded.
#[derive(Debug, Clone)]
pub struct Posterior {
    coords: Vec<Coord>,
    runs: Vec<RunModel>,
    /// Run indices in evaluation order: slides that others follow come first.
    order: Vec<usize>,
    columns: Vec<Column>,
    materials: Vec<String>,
    contacts: Vec<String>,
    contact_material: Vec<usize>,
    populations: Vec<Population>,
    /// Per material: (coordinate of a/F_d or a, is ratio); for the material-level a column.
    material_aging: Vec<Option<(usize, bool)>>,
    /// Per contact: coordinate of F_d.
    contact_fd: Vec<Option<usize>>,
    /// Per material: velocity of its first slow slide, for the new-contact prediction.
    material_velocity: Vec<Option<f64>>,
    /// For each pooled z coordinate, the t0 it makes.
    z_t0: Vec<Option<T0Source>>,
    start: Vec<f64>,
}

/// Errors building a posterior.
#[derive(Debug, thiserror::Error)]
pub enum PosteriorError {
    /// A run's data could not be loaded or is unusable.
    #[error(transparent)]
    Data(#[from] super::data::RunDataError),
    /// A structural problem (e.g. a parameter at a level that does not fit the scenes).
    #[error("{source_file}: {message}")]
    Model {
        /// Model file.
        source_file: PathBuf,
        /// What is wrong and what to do.
        message: String,
    },
}

fn group_of(spec: &ModelSpec, level: Level, run: usize) -> (Level, usize) {
    let contact = spec.run_contact[run];
    match level {
        Level::Material => (level, spec.contact_material[contact]),
        Level::Contact => (level, contact),
        Level::Run => (level, run),
    }
}

fn group_name(spec: &ModelSpec, level: Level, index: usize) -> String {
    match level {
        Level::Material => spec.file.materials[index].name.clone(),
        Level::Contact => spec.file.contacts[index].name.clone(),
        Level::Run => spec.file.runs[index].name.clone(),
    }
}

impl Posterior {
    /// Loads every run's data and lays out the sampled coordinates and reported columns.
    ///
    /// # Errors
    /// [`PosteriorError`] naming the file, line or key at fault.
    pub fn new(spec: &ModelSpec) -> Result<Self, PosteriorError> {
        let n_runs = spec.file.runs.len();
        let mut data = Vec::with_capacity(n_runs);
        for (i, run) in spec.file.runs.iter().enumerate() {
            data.push(RunData::load(&spec.data_path(i), run.window_s, run.scene)?);
        }
        let ratio = spec.file.aging == Aging::Ratio;
        let mut coords: Vec<Coord> = Vec::new();
        let mut columns: Vec<Column> = Vec::new();
        // (param, level, group index) -> coordinate.
        let mut index: std::collections::BTreeMap<(Param, u8, usize), usize> = Default::default();
        let level_key = |l: Level| match l {
            Level::Material => 0u8,
            Level::Contact => 1,
            Level::Run => 2,
        };
        let pooled_t0 = spec.file.pooling.t0;
        let mut populations: Vec<Population> = Vec::new();
        let mut runs = Vec::with_capacity(n_runs);
        for (i, run) in spec.file.runs.iter().enumerate() {
            let coord_of = |p: Param, coords: &mut Vec<Coord>, columns: &mut Vec<Column>, index: &mut std::collections::BTreeMap<(Param, u8, usize), usize>| -> usize {
                let level = spec.level(p);
                let (level, g) = group_of(spec, level, i);
                *index.entry((p, level_key(level), g)).or_insert_with(|| {
                    let group = group_name(spec, level, g);
                    let (name, unit) = if p == Param::A && ratio {
                        ("a_over_F_d", "1")
                    } else {
                        (p.name(), p.unit())
                    };
                    coords.push(Coord {
                        name: format!("ln_{name}[{group}]"),
                        prior: CoordPrior::Log(spec.prior(name)),
                    });
                    columns.push(Column {
                        column: format!("{name}[{group}]"),
                        name: name.into(),
                        group,
                        unit: unit.into(),
                        kind: Kind::Parameter,
                    });
                    coords.len() - 1
                })
            };
            let scene = run.scene;
            let uses = |p: Param| p.used_by(scene);
            let alpha = uses(Param::Alpha).then(|| coord_of(Param::Alpha, &mut coords, &mut columns, &mut index));
            let a = uses(Param::A).then(|| coord_of(Param::A, &mut coords, &mut columns, &mut index));
            let f_d = coord_of(Param::FD, &mut coords, &mut columns, &mut index);
            let t0 = if !uses(Param::T0) {
                None
            } else if pooled_t0 {
                let material = spec.contact_material[spec.run_contact[i]];
                let pop = match populations.iter().find(|p| p.material == material) {
                    Some(p) => *p,
                    None => {
                        let m = spec.file.materials[material].name.clone();
                        coords.push(Coord {
                            name: format!("ln_t0_pop_median[{m}]"),
                            prior: CoordPrior::Log(spec.prior("t0_pop_median")),
                        });
                        columns.push(Column {
                            column: format!("t0_pop_median[{m}]"),
                            name: "t0_pop_median".into(),
                            group: m.clone(),
                            unit: "s".into(),
                            kind: Kind::Parameter,
                        });
                        coords.push(Coord {
                            name: format!("ln_t0_pop_log_sd[{m}]"),
                            prior: CoordPrior::Log(spec.prior("t0_pop_log_sd")),
                        });
                        columns.push(Column {
                            column: format!("t0_pop_log_sd[{m}]"),
                            name: "t0_pop_log_sd".into(),
                            group: m,
                            unit: "1".into(),
                            kind: Kind::Parameter,
                        });
                        let p = Population {
                            material,
                            mu: coords.len() - 2,
                            ln_s: coords.len() - 1,
                        };
                        populations.push(p);
                        p
                    }
                };
                // One z per t0 group (run or contact).
                let (level, g) = group_of(spec, spec.level(Param::T0), i);
                let z = *index.entry((Param::T0, level_key(level), g)).or_insert_with(|| {
                    let group = group_name(spec, level, g);
                    coords.push(Coord {
                        name: format!("z_t0[{group}]"),
                        prior: CoordPrior::StdNormal,
                    });
                    columns.push(Column {
                        column: format!("t0[{group}]"),
                        name: "t0".into(),
                        group,
                        unit: "s".into(),
                        kind: Kind::Parameter,
                    });
                    coords.len() - 1
                });
                Some(T0Source::Pooled {
                    mu: pop.mu,
                    ln_s: pop.ln_s,
                    z,
                })
            } else {
                Some(T0Source::Direct(coord_of(Param::T0, &mut coords, &mut columns, &mut index)))
            };
            let k = uses(Param::K).then(|| coord_of(Param::K, &mut coords, &mut columns, &mut index));
            let sigma = coord_of(Param::Sigma, &mut coords, &mut columns, &mut index);
            let contact = spec.run_contact[i];
            let normal_force = spec.file.contacts[contact]
                .normal_force_n
                .or(data[i].mean_normal_force());
            runs.push(RunModel {
                name: run.name.clone(),
                scene,
                velocity: run.velocity_m_per_s,
                data: data[i].clone(),
                contact,
                alpha,
                a,
                ratio,
                f_d,
                t0,
                k,
                sigma,
                follows: spec.run_follows[i],
                normal_force,
            });
        }
        let n_contacts = spec.file.contacts.len();
        let n_materials = spec.file.materials.len();
        // Columns the coordinates do not give directly.
        let mut contact_fd = vec![None; n_contacts];
        for r in &runs {
            contact_fd[r.contact] = Some(r.f_d);
        }
        if ratio {
            let mut seen = vec![false; n_contacts];
            for r in &runs {
                if r.a.is_some() && !seen[r.contact] {
                    seen[r.contact] = true;
                    let c = spec.file.contacts[r.contact].name.clone();
                    columns.push(Column {
                        column: format!("a[{c}]"),
                        name: "a".into(),
                        group: c,
                        unit: "N".into(),
                        kind: Kind::Parameter,
                    });
                }
            }
        }
        let mut material_aging = vec![None; n_materials];
        let mut material_velocity = vec![None; n_materials];
        for r in &runs {
            let m = spec.contact_material[r.contact];
            if let Some(a) = r.a {
                if spec.level(Param::A) == Level::Material {
                    material_aging[m] = Some((a, r.ratio));
                }
            }
            if r.scene == Scene::First && material_velocity[m].is_none() {
                material_velocity[m] = Some(r.velocity);
            }
        }
        for (m, aging) in material_aging.iter().enumerate() {
            if aging.is_some_and(|(_, is_ratio)| is_ratio) {
                let name = spec.file.materials[m].name.clone();
                columns.push(Column {
                    column: format!("a[{name}]"),
                    name: "a".into(),
                    group: name,
                    unit: "N".into(),
                    kind: Kind::Derived,
                });
            }
        }
        for r in &runs {
            if r.scene == Scene::Repeat {
                continue;
            }
            for (name, unit) in [("F_peak", "N"), ("tau_peak", "s"), ("s_peak", "m"), ("t_peak", "s")] {
                columns.push(Column {
                    column: format!("{name}[{}]", r.name),
                    name: name.into(),
                    group: r.name.clone(),
                    unit: unit.into(),
                    kind: Kind::Derived,
                });
            }
            if r.normal_force.is_some() {
                columns.push(Column {
                    column: format!("mu_s[{}]", r.name),
                    name: "mu_s".into(),
                    group: r.name.clone(),
                    unit: "1".into(),
                    kind: Kind::Derived,
                });
            }
        }
        for p in &populations {
            let m = &spec.file.materials[p.material].name;
            if material_aging[p.material].is_some() && material_velocity[p.material].is_some() {
                columns.push(Column {
                    column: format!("F_peak_new[{m}]"),
                    name: "F_peak_new".into(),
                    group: m.clone(),
                    unit: "N".into(),
                    kind: Kind::Derived,
                });
            }
        }
        // Evaluation order: runs that are followed first.
        let mut order: Vec<usize> = (0..n_runs).filter(|&i| runs[i].scene != Scene::Repeat).collect();
        order.extend((0..n_runs).filter(|&i| runs[i].scene == Scene::Repeat));
        let mut z_t0 = vec![None; coords.len()];
        for r in &runs {
            if let Some(src @ T0Source::Pooled { z, .. }) = r.t0 {
                z_t0[z] = Some(src);
            }
        }
        let mut posterior = Self {
            z_t0,
            coords,
            runs,
            order,
            columns,
            materials: spec.file.materials.iter().map(|m| m.name.clone()).collect(),
            contacts: spec.file.contacts.iter().map(|c| c.name.clone()).collect(),
            contact_material: spec.contact_material.clone(),
            populations,
            material_aging,
            contact_fd,
            material_velocity,
            start: Vec::new(),
        };
        posterior.start = posterior.heuristic_start();
        Ok(posterior)
    }

    /// The reported columns, in the order of the derived values.
    pub fn columns(&self) -> &[Column] {
        &self.columns
    }

    /// Material names.
    pub fn materials(&self) -> &[String] {
        &self.materials
    }

    /// A starting point for the optimiser, from rough features of the data.
    pub fn start(&self) -> &[f64] {
        &self.start
    }

    /// Rough values: F_d from the late first-slide level, k from the repeat slide's loading
    /// slope, α from the time of the maximum, a/F_d from the overshoot, t0 a small fraction
    /// of 1/(αv), σ from successive differences.
    fn heuristic_start(&self) -> Vec<f64> {
        let mut natural = vec![f64::NAN; self.coords.len()];
        let set = |natural: &mut Vec<f64>, i: usize, v: f64| {
            if natural[i].is_nan() && v.is_finite() && v > 0.0 {
                natural[i] = v;
            }
        };
        for r in &self.runs {
            let d = &r.data;
            set(&mut natural, r.sigma, d.noise_estimate());
            let late = d.late_level();
            let peak = d.max_force();
            let f_d = if r.scene == Scene::Repeat { late } else { late.min(peak) };
            set(&mut natural, r.f_d, f_d);
            if let Some(k) = r.k {
                let slope = d.initial_slope();
                let factor = if r.scene == Scene::Repeat { 1.0 } else { 1.5 };
                set(&mut natural, k, factor * slope / r.velocity);
            }
            if r.scene != Scene::Repeat {
                let t_max = d.time_of_max().max(d.duration() * 1e-3);
                let alpha = 0.5 / (r.velocity * t_max);
                if let Some(i) = r.alpha {
                    set(&mut natural, i, alpha);
                }
                if let Some(i) = r.a {
                    let overshoot = ((peak - late) / late).clamp(0.05, 5.0);
                    let v = if r.ratio { overshoot } else { overshoot * late };
                    set(&mut natural, i, v);
                }
                let t0 = 0.01 / (alpha * r.velocity);
                match r.t0 {
                    Some(T0Source::Direct(i)) => set(&mut natural, i, t0),
                    Some(T0Source::Pooled { mu, .. }) => set(&mut natural, mu, t0),
                    None => {}
                }
            }
        }
        for p in &self.populations {
            set(&mut natural, p.ln_s, 0.5);
        }
        self.coords
            .iter()
            .zip(&natural)
            .map(|(c, &v)| match c.prior {
                CoordPrior::StdNormal => 0.0,
                CoordPrior::Log(ref prior) => {
                    let (lo, hi) = prior.bounds();
                    let v = if v.is_nan() { 1.0 } else { v };
                    // Keep the start strictly inside the prior.
                    let v = v.clamp(lo.max(f64::MIN_POSITIVE) * 1.01, hi * 0.99);
                    v.ln()
                }
            })
            .collect()
    }

    fn value(x: &[f64], i: usize) -> f64 {
        x[i].exp()
    }

    fn t0_of(x: &[f64], src: T0Source) -> f64 {
        match src {
            T0Source::Direct(i) => x[i].exp(),
            T0Source::Pooled { mu, ln_s, z } => (x[mu] + x[ln_s].exp() * x[z]).exp(),
        }
    }

    fn law_of(&self, x: &[f64], r: &RunModel) -> Result<Law, LawError> {
        let f_d = Self::value(x, r.f_d);
        let a = match r.a {
            Some(i) if r.ratio => Self::value(x, i) * f_d,
            Some(i) => Self::value(x, i),
            None => 0.0,
        };
        let alpha = r.alpha.map_or(f64::NAN, |i| Self::value(x, i));
        let t0 = r.t0.map_or(f64::NAN, |s| Self::t0_of(x, s));
        Law::from_rate(alpha * r.velocity, a, f_d, t0)
    }

    fn elastic_of(x: &[f64], r: &RunModel) -> Result<Elastic, LawError> {
        match (r.scene, r.k) {
            (Scene::StiffFast, _) | (_, None) => Ok(Elastic::Stiff),
            (_, Some(k)) => Elastic::spring(Self::value(x, k), r.velocity),
        }
    }

    /// Model forces of run `run` at its data times, for posterior predictive curves.
    ///
    /// # Errors
    /// A law error (e.g. stick-slip) at these parameters.
    pub fn run_forces(&self, x: &[f64], run: usize) -> Result<Vec<f64>, LawError> {
        let mut f_end = vec![None; self.runs.len()];
        for &i in &self.order {
            let r = &self.runs[i];
            if r.scene == Scene::First {
                let slide = ObservedSlide::new(self.law_of(x, r)?, Self::elastic_of(x, r)?);
                let mut last = 0.0;
                slide.for_each_force(&r.data.model_times, |_, _, f| last = f)?;
                f_end[i] = Some(last);
            }
        }
        let r = &self.runs[run];
        let mut out = Vec::with_capacity(r.data.n_obs);
        self.visit_run(x, r, &f_end, |_, f| out.push(f))?;
        out.truncate(r.data.n_obs);
        Ok(out)
    }

    /// Visits (index, force) of a run's model at its model times.
    fn visit_run(
        &self,
        x: &[f64],
        r: &RunModel,
        f_end: &[Option<f64>],
        mut visit: impl FnMut(usize, f64),
    ) -> Result<(), LawError> {
        match r.scene {
            Scene::Repeat => {
                let f_d = Self::value(x, r.f_d);
                let end = r.follows.and_then(|j| f_end[j]).unwrap_or(f_d);
                let slide = RepeatSlide::from_elastic(Self::elastic_of(x, r)?, end)?;
                for (i, &t) in r.data.model_times.iter().enumerate() {
                    visit(i, slide.force(t));
                }
                Ok(())
            }
            Scene::First | Scene::StiffFast => {
                let slide = ObservedSlide::new(self.law_of(x, r)?, Self::elastic_of(x, r)?);
                slide.for_each_force(&r.data.model_times, |i, _, f| visit(i, f))
            }
        }
    }

    /// Writes the value of every reported column at `x`, in column order, into `derived`
    /// (of length `columns().len()`).
    pub fn derived_values(&self, x: &[f64], derived: &mut [f64]) {
        let mut out = Out { buf: derived, k: 0 };
        for (i, c) in self.coords.iter().enumerate() {
            match c.prior {
                CoordPrior::Log(_) => out.push(x[i].exp()),
                // The column of a z is the t0 it makes.
                CoordPrior::StdNormal => out.push(self.z_t0[i].map_or(f64::NAN, |s| Self::t0_of(x, s))),
            }
        }
        // a per contact (ratio parameterisation).
        if self.runs.first().is_some_and(|r| r.ratio) {
            let mut seen = vec![false; self.contacts.len()];
            for r in &self.runs {
                if let Some(a) = r.a {
                    if !seen[r.contact] {
                        seen[r.contact] = true;
                        out.push(x[a].exp() * x[r.f_d].exp());
                    }
                }
            }
        }
        // a per material: a/F_d times the mean F_d of the material's contacts.
        for (m, aging) in self.material_aging.iter().enumerate() {
            if let Some((a, true)) = aging {
                out.push(x[*a].exp() * self.mean_fd(x, m));
            }
        }
        for r in &self.runs {
            if r.scene == Scene::Repeat {
                continue;
            }
            let peak = self.law_of(x, r).ok().and_then(|law| law.peak().interior());
            let kv = match Self::elastic_of(x, r) {
                Ok(Elastic::Spring { kv }) => Some(kv),
                _ => None,
            };
            match peak {
                Some(p) => {
                    out.push(p.force_n);
                    out.push(p.tau_s);
                    out.push(p.slip_m(r.velocity));
                    out.push(p.observed_time_s(kv));
                }
                None => (0..4).for_each(|_| out.push(f64::NAN)),
            }
            if let Some(fn_) = r.normal_force {
                out.push(peak.map_or(f64::NAN, |p| p.force_n / fn_));
            }
        }
        for p in &self.populations {
            let m = p.material;
            let (Some((a, is_ratio)), Some(v)) = (self.material_aging[m], self.material_velocity[m]) else {
                continue;
            };
            let alpha = self
                .runs
                .iter()
                .find(|r| self.contact_material[r.contact] == m && r.alpha.is_some())
                .and_then(|r| r.alpha)
                .map_or(f64::NAN, |i| x[i].exp());
            let f_d = self.mean_fd(x, m);
            let a_val = if is_ratio { x[a].exp() * f_d } else { x[a].exp() };
            // A new contact's t0 from the material's population, with a standard-normal draw
            // made a deterministic function of the draw itself so that the sampler stays
            // reproducible; hashing the bits makes it independent of the parameter values.
            let z = hashed_normal(x, m as u64);
            let t0 = (x[p.mu] + x[p.ln_s].exp() * z).exp();
            let f = Law::from_rate(alpha * v, a_val, f_d, t0)
                .ok()
                .and_then(|law| law.peak().interior())
                .map_or(f64::NAN, |p| p.force_n);
            out.push(f);
        }
        debug_assert_eq!(out.k, out.buf.len());
    }

    fn mean_fd(&self, x: &[f64], material: usize) -> f64 {
        let (mut sum, mut n) = (0.0, 0.0);
        for (c, &m) in self.contact_material.iter().enumerate() {
            if m == material {
                if let Some(i) = self.contact_fd[c] {
                    sum += x[i].exp();
                    n += 1.0;
                }
            }
        }
        sum / n
    }

    fn log_prior(&self, x: &[f64]) -> Result<f64, LogDensityError> {
        let mut lp = 0.0;
        for (c, &u) in self.coords.iter().zip(x) {
            lp += match &c.prior {
                CoordPrior::Log(prior) => {
                    let l = prior.ln_density(u.exp());
                    if l == f64::NEG_INFINITY {
                        return Err(LogDensityError::rejected(REJECT_PRIOR));
                    }
                    l + u
                }
                CoordPrior::StdNormal => -0.5 * u * u - LN_SQRT_2PI,
            };
        }
        Ok(lp)
    }
}

/// A cursor writing derived values in order.
struct Out<'a> {
    buf: &'a mut [f64],
    k: usize,
}

impl Out<'_> {
    fn push(&mut self, v: f64) {
        self.buf[self.k] = v;
        self.k += 1;
    }
}

/// A standard-normal number that is a deterministic function of the bits of `x` and `salt`
/// (SplitMix64 hashing, then the Box–Muller transform).
fn hashed_normal(x: &[f64], salt: u64) -> f64 {
    fn mix(h: &mut u64, v: u64) {
        *h = h.wrapping_add(v).wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = *h;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        *h = z ^ (z >> 31);
    }
    let mut h = 0x9E37_79B9_7F4A_7C15_u64 ^ salt;
    for v in x {
        mix(&mut h, v.to_bits());
    }
    let u1 = ((h >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    mix(&mut h, 1);
    let u2 = ((h >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

impl LogDensity for Posterior {
    fn dim(&self) -> usize {
        self.coords.len()
    }

    fn param_names(&self) -> Vec<String> {
        self.coords.iter().map(|c| c.name.clone()).collect()
    }

    fn derived_names(&self) -> Vec<String> {
        self.columns.iter().map(|c| c.column.clone()).collect()
    }

    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        let mut lp = self.log_prior(x)?;
        let law_error = |e: LawError| match e {
            LawError::StickSlip { .. } => LogDensityError::rejected(REJECT_STICK_SLIP),
            _ => LogDensityError::rejected(REJECT_LAW),
        };
        let mut f_end = [None; 64];
        let mut f_end_vec;
        let f_end: &mut [Option<f64>] = if self.runs.len() <= f_end.len() {
            &mut f_end[..self.runs.len()]
        } else {
            f_end_vec = vec![None; self.runs.len()];
            &mut f_end_vec
        };
        for &i in &self.order {
            let r = &self.runs[i];
            let sigma = Self::value(x, r.sigma);
            let obs = &r.data.force;
            let n = r.data.n_obs;
            let mut ssr = 0.0;
            let mut last = 0.0;
            self.visit_run(x, r, f_end, |j, f| {
                if j < n {
                    let e = obs[j] - f;
                    ssr += e * e;
                }
                last = f;
            })
            .map_err(law_error)?;
            if r.scene == Scene::First {
                f_end[i] = Some(last);
            }
            lp += -(n as f64) * (sigma.ln() + LN_SQRT_2PI) - 0.5 * ssr / (sigma * sigma);
        }
        if !derived.is_empty() {
            self.derived_values(x, derived);
        }
        Ok(lp)
    }
}
