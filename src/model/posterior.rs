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
use crate::density::{LogDensity, LogDensityError};
use crate::law::{Elastic, Law, LawError, ObservedSlide, RepeatSlide, Scene};
use crate::optimize::{nelder_mead, NelderMeadOptions};

/// Log of √(2π).
const LN_SQRT_2PI: f64 = 0.918_938_533_204_672_8;

/// Most runs a model may have (the likelihood keeps per-run scratch on the stack).
pub const MAX_RUNS: usize = 256;

/// ln ∫ N(residuals | 0, σ²) p(σ) dσ for a log-uniform p(σ) on [low, high], given the sum of
/// squared residuals and their number:
/// −n ln√(2π) + ln Γ(n/2) − ln 2 − (n/2) ln(SSR/2) − ln ln(high/low) + ln[P(n/2, SSR/(2low²))
/// − P(n/2, SSR/(2high²))], P the regularised lower incomplete gamma function (the truncation
/// to the prior's bounds). `None` only for SSR ≤ 0 or NaN: far from the data the truncation
/// mass is tiny but is kept in log space, so an optimiser started there can still climb.
fn marginal_sigma_log_likelihood(ssr: f64, n: usize, low: f64, high: f64) -> Option<f64> {
    use statrs::function::gamma::ln_gamma;
    if n == 0 {
        return Some(0.0);
    }
    if ssr.is_nan() || ssr <= 0.0 {
        return None;
    }
    let half_n = 0.5 * n as f64;
    let half_ssr = 0.5 * ssr;
    let ln_mass = ln_gamma_p_difference(half_n, half_ssr / (high * high), half_ssr / (low * low))?;
    Some(
        -(n as f64) * LN_SQRT_2PI + ln_gamma(half_n)
            - std::f64::consts::LN_2
            - half_n * half_ssr.ln()
            - (high / low).ln().ln()
            + ln_mass,
    )
}

/// ln[P(s, x_hi) − P(s, x_lo)] for 0 < x_lo < x_hi, P the regularised lower incomplete gamma
/// function. When both arguments lie in one tail, the difference of two values near zero (or
/// near one) underflows (or cancels) in linear space, so it is formed from logarithms of P
/// (lower tail, by its series) or of Q = 1 − P (upper tail, by its continued fraction).
fn ln_gamma_p_difference(s: f64, x_lo: f64, x_hi: f64) -> Option<f64> {
    use statrs::function::gamma::gamma_lr;
    let ln_diff = |ln_big: f64, ln_small: f64| {
        let d = ln_big + (-(ln_small - ln_big).exp()).ln_1p();
        d.is_finite().then_some(d)
    };
    if x_lo > s + 1.0 {
        ln_diff(ln_gamma_q_cf(s, x_lo), ln_gamma_q_cf(s, x_hi))
    } else if x_hi <= s + 1.0 {
        ln_diff(ln_gamma_p_series(s, x_hi), ln_gamma_p_series(s, x_lo))
    } else {
        let mass = gamma_lr(s, x_hi) - gamma_lr(s, x_lo);
        (mass > 0.0).then(|| mass.ln())
    }
}

/// A draw of σ from its conditional posterior when nearly all of it lies outside the prior's
/// bounds [low, high] (far from the data, e.g. at a walker's start), where plain rejection
/// fails. With u = SSR/(2σ²), u ~ Gamma(n/2, 1) truncated to [SSR/(2high²), SSR/(2low²)].
/// Above the bounds (the lower truncation point u_h beyond the mode): exact rejection from the
/// shifted exponential u = u_h + E/λ, λ = 1 − (n/2 − 1)/u_h, whose acceptance
/// exp((n/2 − 1)[ln(u/u_h) − (u − u_h)/u_h]) ≤ 1. Below the bounds, or if that fails, the
/// bound where the mass piles up: an approximation only ever needed before burn-in.
fn truncated_sigma_tail_draw<R: rand::Rng>(
    ssr: f64,
    n: usize,
    low: f64,
    high: f64,
    rng: &mut R,
) -> f64 {
    use rand_distr::{Distribution, Exp1};
    let s = 0.5 * n as f64;
    let u_h = 0.5 * ssr / (high * high);
    let u_l = 0.5 * ssr / (low * low);
    if u_h <= s + 1.0 || u_h.is_nan() {
        return low;
    }
    let lambda = 1.0 - (s - 1.0) / u_h;
    for _ in 0..1000 {
        let e: f64 = Exp1.sample(rng);
        let u = u_h + e / lambda;
        let accept = ((s - 1.0) * ((u / u_h).ln() - (u - u_h) / u_h)).exp();
        if u <= u_l && rng.random::<f64>() < accept {
            return (0.5 * ssr / u).sqrt();
        }
    }
    high
}

/// Terms of the incomplete gamma series and continued fraction, at most (both converge in
/// far fewer where they are used: x ≤ s + 1 for the series, x > s + 1 for the fraction).
const INCOMPLETE_GAMMA_MAX_TERMS: usize = 100_000;

/// ln P(s, x) from P = x^s e^(−x) / Γ(s + 1) · Σ_k x^k / ((s + 1)⋯(s + k)).
fn ln_gamma_p_series(s: f64, x: f64) -> f64 {
    use statrs::function::gamma::ln_gamma;
    let (mut term, mut sum) = (1.0_f64, 1.0_f64);
    for k in 1..INCOMPLETE_GAMMA_MAX_TERMS {
        term *= x / (s + k as f64);
        sum += term;
        if term < sum * f64::EPSILON {
            break;
        }
    }
    s * x.ln() - x - ln_gamma(s + 1.0) + sum.ln()
}

/// ln Q(s, x) from the continued fraction of Γ(s, x) (modified Lentz, as in Numerical
/// Recipes' `gcf`).
fn ln_gamma_q_cf(s: f64, x: f64) -> f64 {
    use statrs::function::gamma::ln_gamma;
    let tiny = 1e-300;
    let mut b = x + 1.0 - s;
    let mut c = 1.0 / tiny;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..INCOMPLETE_GAMMA_MAX_TERMS {
        let an = -(i as f64) * (i as f64 - s);
        b += 2.0;
        d = an * d + b;
        if d.abs() < tiny {
            d = tiny;
        }
        c = b + an / c;
        if c.abs() < tiny {
            c = tiny;
        }
        d = 1.0 / d;
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() < f64::EPSILON {
            break;
        }
    }
    s * x.ln() - x - ln_gamma(s) + h.ln()
}

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
    /// How its value is computed.
    #[serde(skip)]
    source: Source,
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
#[derive(Debug, Clone, Copy, PartialEq)]
enum T0Source {
    Direct(usize),
    /// ln t0 = x[mu] + exp(x[ln_s]) x[z].
    Pooled {
        mu: usize,
        ln_s: usize,
        z: usize,
    },
}

/// Where a run's noise level comes from.
#[derive(Debug, Clone, Copy)]
enum SigmaSource {
    /// A sampled coordinate ln σ.
    Coord(usize),
    /// Integrated out analytically (log-uniform prior): the index of its group.
    Marginal(usize),
}

/// Runs sharing one σ that is integrated out: σ ~ log-uniform on [low, high].
#[derive(Debug, Clone)]
struct SigmaGroup {
    low: f64,
    high: f64,
    /// Salt of the conditional draw reported for σ.
    salt: u64,
}

/// How the value of a reported column is computed from a draw.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    /// exp of a log-scale coordinate.
    Coord(usize),
    /// A pooled t0.
    T0(T0Source),
    /// σ of a marginalised group, drawn from its conditional posterior.
    Sigma(usize),
    /// a = (a/F_d) · F_d of a contact.
    AContact { ratio: usize, f_d: usize },
    /// a/F_d of a material times its contacts' mean F_d.
    AMaterial(usize),
    /// Field of a run's peak: 0 F_peak, 1 τ_peak, 2 s_peak, 3 t_peak, 4 μ_s.
    Peak { run: usize, field: u8 },
    /// Peak of a new contact of a pooled material.
    PeakNew(usize),
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
    sigma: SigmaSource,
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
    sigma_groups: Vec<SigmaGroup>,
    materials: Vec<String>,
    contact_material: Vec<usize>,
    populations: Vec<Population>,
    /// Per material: (coordinate of a/F_d or a, is ratio); for the material-level a column.
    material_aging: Vec<Option<(usize, bool)>>,
    /// Per contact: coordinate of F_d.
    contact_fd: Vec<Option<usize>>,
    /// Per material: velocity of its first slow slide, for the new-contact prediction.
    material_velocity: Vec<Option<f64>>,
    start: Vec<f64>,
}

/// Posterior and posterior predictive bands of one run at (a subset of) its data times.
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    /// Run name.
    pub run: String,
    /// Instrument times (s).
    pub time_s: Vec<f64>,
    /// Observed force (N).
    pub observed_n: Vec<f64>,
    /// Model force (no noise): 2.5 %, 50 % and 97.5 % quantiles over the draws (N).
    pub model_n: [Vec<f64>; 3],
    /// Predictive force (model plus noise): 2.5 %, 25 %, 75 % and 97.5 % quantiles (N).
    pub predictive_n: [Vec<f64>; 4],
}

/// Estimates from one slide fitted alone (a start for the joint fit).
#[derive(Debug, Clone, Copy)]
struct RunAlone {
    /// Root-mean-square residual (N).
    sigma: f64,
    alpha: f64,
    ratio: f64,
    t0: f64,
    f_d: f64,
    k: Option<f64>,
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
        if n_runs > MAX_RUNS {
            return Err(PosteriorError::Model {
                source_file: spec.source.clone(),
                message: format!("{n_runs} runs; a model may have at most {MAX_RUNS}: split it"),
            });
        }
        let mut data = Vec::with_capacity(n_runs);
        for i in 0..n_runs {
            data.push(RunData::for_run(spec, i)?);
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
        let mut sigma_groups: Vec<SigmaGroup> = Vec::new();
        let mut sigma_index: std::collections::BTreeMap<(u8, usize), usize> = Default::default();
        let mut runs = Vec::with_capacity(n_runs);
        for (i, run) in spec.file.runs.iter().enumerate() {
            let coord_of = |p: Param,
                            coords: &mut Vec<Coord>,
                            columns: &mut Vec<Column>,
                            index: &mut std::collections::BTreeMap<(Param, u8, usize), usize>|
             -> usize {
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
                        source: Source::Coord(coords.len() - 1),
                    });
                    coords.len() - 1
                })
            };
            let scene = run.scene;
            let uses = |p: Param| p.used_by(scene);
            let alpha = uses(Param::Alpha)
                .then(|| coord_of(Param::Alpha, &mut coords, &mut columns, &mut index));
            let a =
                uses(Param::A).then(|| coord_of(Param::A, &mut coords, &mut columns, &mut index));
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
                            source: Source::Coord(coords.len() - 1),
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
                            source: Source::Coord(coords.len() - 1),
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
                let z = *index
                    .entry((Param::T0, level_key(level), g))
                    .or_insert_with(|| {
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
                            source: Source::T0(T0Source::Pooled {
                                mu: pop.mu,
                                ln_s: pop.ln_s,
                                z: coords.len() - 1,
                            }),
                        });
                        coords.len() - 1
                    });
                Some(T0Source::Pooled {
                    mu: pop.mu,
                    ln_s: pop.ln_s,
                    z,
                })
            } else {
                Some(T0Source::Direct(coord_of(
                    Param::T0,
                    &mut coords,
                    &mut columns,
                    &mut index,
                )))
            };
            let k =
                uses(Param::K).then(|| coord_of(Param::K, &mut coords, &mut columns, &mut index));
            let sigma = match spec.prior("sigma") {
                // A log-uniform σ integrates out in closed form: one dimension less per σ.
                Prior::LogUniform { low, high } => {
                    let (level, g) = group_of(spec, spec.level(Param::Sigma), i);
                    let next = sigma_groups.len();
                    let k = *sigma_index.entry((level_key(level), g)).or_insert(next);
                    if k == next {
                        let group = group_name(spec, level, g);
                        sigma_groups.push(SigmaGroup {
                            low,
                            high,
                            salt: 0x5165_0000 + k as u64,
                        });
                        columns.push(Column {
                            column: format!("sigma[{group}]"),
                            name: "sigma".into(),
                            group,
                            unit: "N".into(),
                            kind: Kind::Parameter,
                            source: Source::Sigma(k),
                        });
                    }
                    SigmaSource::Marginal(k)
                }
                _ => SigmaSource::Coord(coord_of(
                    Param::Sigma,
                    &mut coords,
                    &mut columns,
                    &mut index,
                )),
            };
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
                        source: Source::AContact {
                            ratio: r.a.unwrap_or(0),
                            f_d: r.f_d,
                        },
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
                    source: Source::AMaterial(m),
                });
            }
        }
        for (run, r) in runs.iter().enumerate() {
            if r.scene == Scene::Repeat {
                continue;
            }
            for (field, (name, unit)) in [
                ("F_peak", "N"),
                ("tau_peak", "s"),
                ("s_peak", "m"),
                ("t_peak", "s"),
            ]
            .into_iter()
            .enumerate()
            {
                columns.push(Column {
                    column: format!("{name}[{}]", r.name),
                    name: name.into(),
                    group: r.name.clone(),
                    unit: unit.into(),
                    kind: Kind::Derived,
                    source: Source::Peak {
                        run,
                        field: field as u8,
                    },
                });
            }
            if r.normal_force.is_some() {
                columns.push(Column {
                    column: format!("mu_s[{}]", r.name),
                    name: "mu_s".into(),
                    group: r.name.clone(),
                    unit: "1".into(),
                    kind: Kind::Derived,
                    source: Source::Peak { run, field: 4 },
                });
            }
        }
        for (pop, p) in populations.iter().enumerate() {
            let m = &spec.file.materials[p.material].name;
            if material_aging[p.material].is_some() && material_velocity[p.material].is_some() {
                columns.push(Column {
                    column: format!("F_peak_new[{m}]"),
                    name: "F_peak_new".into(),
                    group: m.clone(),
                    unit: "N".into(),
                    kind: Kind::Derived,
                    source: Source::PeakNew(pop),
                });
            }
        }
        // Evaluation order: runs that are followed first.
        let mut order: Vec<usize> = (0..n_runs)
            .filter(|&i| runs[i].scene != Scene::Repeat)
            .collect();
        order.extend((0..n_runs).filter(|&i| runs[i].scene == Scene::Repeat));
        let mut posterior = Self {
            sigma_groups,
            coords,
            runs,
            order,
            columns,
            materials: spec.file.materials.iter().map(|m| m.name.clone()).collect(),
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

    /// The reported columns as the quantities a fit summarises.
    pub fn quantities(&self) -> Vec<crate::density::Quantity> {
        use crate::density::{Quantity, QuantityKind};
        self.columns
            .iter()
            .map(|c| Quantity {
                column: c.column.clone(),
                name: c.name.clone(),
                group: c.group.clone(),
                unit: c.unit.clone(),
                kind: match c.kind {
                    Kind::Parameter => QuantityKind::Parameter,
                    Kind::Derived => QuantityKind::Derived,
                },
            })
            .collect()
    }

    /// Each sampled coordinate with a sentence describing its prior.
    pub fn prior_descriptions(&self) -> Vec<(String, String)> {
        self.coords
            .iter()
            .map(|c| {
                let d = match &c.prior {
                    CoordPrior::Log(p) => format!("ln of a parameter with prior {}", p.describe()),
                    CoordPrior::StdNormal => "standard normal (non-centred pooled t0)".to_string(),
                };
                (c.name.clone(), d)
            })
            .collect()
    }

    /// Where each run's data came from and what was done to them (the `data` of
    /// `summary.json`).
    pub fn data_provenance(&self) -> Vec<crate::data::Provenance> {
        self.runs
            .iter()
            .map(|r| r.data.provenance.clone())
            .collect()
    }

    /// Observations in the longest run.
    pub fn max_points(&self) -> usize {
        self.runs.iter().map(|r| r.data.n_obs).max().unwrap_or(0)
    }

    /// Material names.
    pub fn materials(&self) -> &[String] {
        &self.materials
    }

    /// A starting point for the optimiser, from rough features of the data.
    pub fn start(&self) -> &[f64] {
        &self.start
    }

    /// A start near the mode, so that one optimisation finds the right basin: k and F_d from
    /// each repeat slide (its loading slope and plateau), then every first or fast slide
    /// fitted on its own (α, a/F_d, t0, F_d and, without a repeat slide, k; σ profiled out)
    /// from a few values of α spanning the record, and the results combined by level
    /// (geometric means for shared parameters).
    fn heuristic_start(&self) -> Vec<f64> {
        let mut natural = vec![f64::NAN; self.coords.len()];
        // Shared parameters collect one estimate per run and take the geometric mean.
        let mut votes: Vec<Vec<f64>> = vec![Vec::new(); self.coords.len()];
        let mut k_known = vec![None; self.contact_material.len()];
        for r in self.runs.iter().filter(|r| r.scene == Scene::Repeat) {
            let d = &r.data;
            let kv = d.initial_slope();
            if let Some(k) = r.k {
                votes[k].push(kv / r.velocity);
                k_known[r.contact] = Some(kv / r.velocity);
            }
            votes[r.f_d].push(d.late_level());
        }
        // A σ sampled explicitly (a prior other than log-uniform) starts at the residual
        // noise of its run: from the run's own fit, or from successive differences on the
        // piecewise-linear repeat slide.
        let vote_sigma = |votes: &mut Vec<Vec<f64>>, r: &RunModel, sigma: f64| {
            if let SigmaSource::Coord(i) = r.sigma {
                votes[i].push(sigma);
            }
        };
        for r in self.runs.iter().filter(|r| r.scene == Scene::Repeat) {
            vote_sigma(&mut votes, r, r.data.noise_estimate());
        }
        let mut t0_votes: Vec<(usize, f64)> = Vec::new();
        for r in self.runs.iter().filter(|r| r.scene != Scene::Repeat) {
            let fitted = self.fit_run_alone(r, k_known[r.contact]);
            vote_sigma(&mut votes, r, fitted.sigma);
            if let Some(i) = r.alpha {
                votes[i].push(fitted.alpha);
            }
            if let Some(i) = r.a {
                votes[i].push(if r.ratio {
                    fitted.ratio
                } else {
                    fitted.ratio * fitted.f_d
                });
            }
            votes[r.f_d].push(fitted.f_d);
            if let (Some(k), Some(v)) = (r.k, fitted.k) {
                if k_known[r.contact].is_none() {
                    votes[k].push(v);
                }
            }
            match r.t0 {
                Some(T0Source::Direct(i)) => votes[i].push(fitted.t0),
                Some(T0Source::Pooled { z, .. }) => t0_votes.push((z, fitted.t0)),
                None => {}
            }
        }
        for (i, v) in votes.iter().enumerate() {
            if !v.is_empty() {
                natural[i] = (v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64).exp();
            }
        }
        // Pooled t0: the population median from its runs, a moderate spread, and each run's
        // standardised offset.
        for p in &self.populations {
            let logs: Vec<(usize, f64)> = t0_votes
                .iter()
                .filter(|(z, _)| self.z_population(*z) == Some(p.mu))
                .map(|&(z, t0)| (z, t0.ln()))
                .collect();
            if logs.is_empty() {
                continue;
            }
            let mu = logs.iter().map(|(_, l)| l).sum::<f64>() / logs.len() as f64;
            natural[p.mu] = mu.exp();
            natural[p.ln_s] = 0.5;
            for (z, l) in logs {
                natural[z] = (l - mu) / 0.5;
            }
        }
        self.coords
            .iter()
            .zip(&natural)
            .map(|(c, &v)| match c.prior {
                CoordPrior::StdNormal => {
                    if v.is_finite() {
                        v
                    } else {
                        0.0
                    }
                }
                CoordPrior::Log(ref prior) => {
                    let (lo, hi) = prior.bounds();
                    let v = if v.is_finite() && v > 0.0 { v } else { 1.0 };
                    // Keep the start strictly inside the prior.
                    v.clamp(lo.max(f64::MIN_POSITIVE) * 1.01, hi * 0.99).ln()
                }
            })
            .collect()
    }

    /// The population (its μ coordinate) a pooled z belongs to.
    fn z_population(&self, z: usize) -> Option<usize> {
        self.runs.iter().find_map(|r| match r.t0 {
            Some(T0Source::Pooled { mu, z: zz, .. }) if zz == z => Some(mu),
            _ => None,
        })
    }

    /// Least squares of one first or fast slide alone, σ profiled out (minimises ln SSR),
    /// with k fixed when a repeat slide gave it.
    fn fit_run_alone(&self, r: &RunModel, k_known: Option<f64>) -> RunAlone {
        let d = &r.data;
        let late = d.late_level();
        let peak = d.max_force();
        let f_d0 = late.min(peak);
        let t_end = d.model_times[d.n_obs - 1].max(f64::MIN_POSITIVE);
        let k0 = k_known.unwrap_or(1.5 * d.initial_slope() / r.velocity);
        let free_k = r.scene == Scene::First && k_known.is_none();
        let ssr = |p: &[f64]| -> f64 {
            let (alpha, ratio, t0, f_d) = (p[0].exp(), p[1].exp(), p[2].exp(), p[3].exp());
            let k = if free_k { p[4].exp() } else { k0 };
            let Ok(law) = Law::from_rate(alpha * r.velocity, ratio * f_d, f_d, t0) else {
                return f64::INFINITY;
            };
            let elastic = match r.scene {
                Scene::First => match Elastic::spring(k, r.velocity) {
                    Ok(e) => e,
                    Err(_) => return f64::INFINITY,
                },
                _ => Elastic::Stiff,
            };
            let mut sum = 0.0;
            let obs = &d.force;
            let ok = ObservedSlide::new(law, elastic).for_each_force(&d.model_times, |j, _, f| {
                if j < d.n_obs {
                    sum += d.weight(j) * (obs[j] - f).powi(2);
                }
            });
            if ok.is_err() {
                f64::INFINITY
            } else {
                sum.ln()
            }
        };
        let options = NelderMeadOptions {
            initial_step: 0.5,
            max_evals: 800,
            restarts: 1,
            ..NelderMeadOptions::default()
        };
        let mut best: Option<(Vec<f64>, f64)> = None;
        // α such that the record spans x = αvt of 1, 5 and 25 at its end.
        for x_end in [1.0, 5.0, 25.0] {
            let alpha = x_end / (r.velocity * t_end);
            let overshoot = ((peak - late) / late).clamp(0.05, 5.0);
            let t0 = 1e-3 / (alpha * r.velocity);
            let mut p = vec![alpha.ln(), overshoot.ln(), t0.ln(), f_d0.ln()];
            if free_k {
                p.push(k0.ln());
            }
            let (x, f, _) = nelder_mead(&ssr, &p, &options);
            if best.as_ref().is_none_or(|(_, fb)| f < *fb) {
                best = Some((x, f));
            }
        }
        let (x, ln_ssr) = best.unwrap_or_default();
        let get = |i: usize| x.get(i).map_or(f64::NAN, |v| v.exp());
        RunAlone {
            sigma: (ln_ssr.exp() / d.n_obs as f64).sqrt(),
            alpha: get(0),
            ratio: get(1),
            t0: get(2),
            f_d: get(3),
            k: if free_k { Some(get(4)) } else { None },
        }
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

    /// The first or fast slide of run `run` at the sampler coordinates `x`: its law in
    /// interface time and the machine's elasticity, so that a report can redraw curves the
    /// data do not sample (interface time, sliding distance, the peak against t0). `None` for
    /// a repeat slide, which has no law of its own.
    ///
    /// # Errors
    /// A law error (invalid parameters) at `x`.
    pub fn run_slide(&self, x: &[f64], run: usize) -> Result<Option<ObservedSlide>, LawError> {
        let r = &self.runs[run];
        if r.scene == Scene::Repeat {
            return Ok(None);
        }
        Ok(Some(ObservedSlide::new(
            self.law_of(x, r)?,
            Self::elastic_of(x, r)?,
        )))
    }

    /// Posterior (model) and posterior predictive (model plus noise) bands of every run at
    /// every `stride`-th data time, from `draws` (sampler coordinates). The noise of each draw
    /// comes from a ChaCha8 stream seeded with `seed`, so the bands are reproducible.
    ///
    /// # Errors
    /// A law error at one of the draws (which a posterior draw cannot produce).
    pub fn predictive_bands(
        &self,
        draws: &[Vec<f64>],
        stride: usize,
        seed: u64,
    ) -> Result<Vec<Band>, LawError> {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let stride = stride.max(1);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut derived = vec![0.0; self.columns.len()];
        // forces[run][draw][point], noisy[run][draw][point]
        let mut model: Vec<Vec<Vec<f64>>> = vec![Vec::with_capacity(draws.len()); self.runs.len()];
        let mut noisy: Vec<Vec<Vec<f64>>> = vec![Vec::with_capacity(draws.len()); self.runs.len()];
        for x in draws {
            // Fills the derived values, σ of marginalised groups among them.
            if self.log_density(x, &mut derived).is_err() {
                continue;
            }
            for (i, r) in self.runs.iter().enumerate() {
                let sigma = match r.sigma {
                    SigmaSource::Coord(c) => x[c].exp(),
                    SigmaSource::Marginal(g) => self
                        .columns
                        .iter()
                        .position(|c| c.source == Source::Sigma(g))
                        .map_or(f64::NAN, |k| derived[k]),
                };
                let f: Vec<f64> = self.run_forces(x, i)?.into_iter().step_by(stride).collect();
                // A bin mean of w points scatters by σ/√w.
                let z: Vec<f64> = f
                    .iter()
                    .enumerate()
                    .map(|(k, v)| {
                        let e: f64 = StandardNormal.sample(&mut rng);
                        v + sigma / r.data.weight(k * stride).sqrt() * e
                    })
                    .collect();
                model[i].push(f);
                noisy[i].push(z);
            }
        }
        let quantiles = |sets: &[Vec<f64>], j: usize, p: f64| {
            let mut column: Vec<f64> = sets.iter().map(|s| s[j]).collect();
            column.sort_by(f64::total_cmp);
            crate::diagnostics::quantile(&column, p).unwrap_or(f64::NAN)
        };
        Ok(self
            .runs
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let idx: Vec<usize> = (0..r.data.n_obs).step_by(stride).collect();
                let q = |sets: &[Vec<f64>], p: f64| {
                    (0..idx.len())
                        .map(|j| quantiles(sets, j, p))
                        .collect::<Vec<f64>>()
                };
                Band {
                    run: r.name.clone(),
                    time_s: idx.iter().map(|&j| r.data.model_times[j]).collect(),
                    observed_n: idx.iter().map(|&j| r.data.force[j]).collect(),
                    model_n: [q(&model[i], 0.025), q(&model[i], 0.5), q(&model[i], 0.975)],
                    predictive_n: [
                        q(&noisy[i], 0.025),
                        q(&noisy[i], 0.25),
                        q(&noisy[i], 0.75),
                        q(&noisy[i], 0.975),
                    ],
                }
            })
            .collect())
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
    /// (of length `columns().len()`). `sigma_fit[g]` = (sum of squared residuals, points) of
    /// marginalised σ group g at `x`, for the conditional draw of σ.
    fn derived_values(&self, x: &[f64], sigma_fit: &[(f64, usize)], derived: &mut [f64]) {
        // Peaks are computed once per run and read by several columns.
        let mut peak_cache: Option<(usize, Option<crate::law::Peak>, Option<f64>)> = None;
        for (out, column) in derived.iter_mut().zip(&self.columns) {
            *out = match column.source {
                Source::Coord(i) => x[i].exp(),
                Source::T0(src) => Self::t0_of(x, src),
                Source::Sigma(g) => {
                    let (ssr, n) = sigma_fit[g];
                    self.sigma_draw(x, g, ssr, n)
                }
                Source::AContact { ratio, f_d } => x[ratio].exp() * x[f_d].exp(),
                Source::AMaterial(m) => self.material_aging[m]
                    .map_or(f64::NAN, |(a, _)| x[a].exp() * self.mean_fd(x, m)),
                Source::Peak { run, field } => {
                    let (_, peak, kv) = match peak_cache {
                        Some(c) if c.0 == run => c,
                        _ => {
                            let r = &self.runs[run];
                            let peak = self.law_of(x, r).ok().and_then(|law| law.peak().interior());
                            let kv = match Self::elastic_of(x, r) {
                                Ok(Elastic::Spring { kv }) => Some(kv),
                                _ => None,
                            };
                            let c = (run, peak, kv);
                            peak_cache = Some(c);
                            c
                        }
                    };
                    let r = &self.runs[run];
                    peak.map_or(f64::NAN, |p| match field {
                        0 => p.force_n,
                        1 => p.tau_s,
                        2 => p.slip_m(r.velocity),
                        3 => p.observed_time_s(kv),
                        _ => r.normal_force.map_or(f64::NAN, |fn_| p.force_n / fn_),
                    })
                }
                Source::PeakNew(pop) => self.new_contact_peak(x, &self.populations[pop]),
            };
        }
    }

    /// The peak of a new contact of a pooled material: its t0 drawn from the material's t0
    /// population, F_d the mean of the material's contacts, at the material's slow velocity.
    fn new_contact_peak(&self, x: &[f64], p: &Population) -> f64 {
        let m = p.material;
        let (Some((a, is_ratio)), Some(v)) = (self.material_aging[m], self.material_velocity[m])
        else {
            return f64::NAN;
        };
        let alpha = self
            .runs
            .iter()
            .find(|r| self.contact_material[r.contact] == m && r.alpha.is_some())
            .and_then(|r| r.alpha)
            .map_or(f64::NAN, |i| x[i].exp());
        let f_d = self.mean_fd(x, m);
        let a_val = if is_ratio {
            x[a].exp() * f_d
        } else {
            x[a].exp()
        };
        // The standard-normal draw is a deterministic function of the draw itself so that the
        // sampler stays reproducible; hashing the bits makes it independent of the values.
        let z = hashed_normal(x, m as u64);
        let t0 = (x[p.mu] + x[p.ln_s].exp() * z).exp();
        Law::from_rate(alpha * v, a_val, f_d, t0)
            .ok()
            .and_then(|law| law.peak().interior())
            .map_or(f64::NAN, |p| p.force_n)
    }

    /// σ of marginalised group `g` drawn from its conditional posterior given the other
    /// parameters: σ² = SSR / χ²_n, truncated to the prior's bounds. Together with the
    /// sampled parameters this is an exact draw from the joint posterior.
    fn sigma_draw(&self, x: &[f64], g: usize, ssr: f64, n: usize) -> f64 {
        use rand::SeedableRng;
        use rand_distr::{ChiSquared, Distribution};
        let group = &self.sigma_groups[g];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(hash_bits(x, group.salt));
        let Ok(chi2) = ChiSquared::new(n as f64) else {
            return f64::NAN;
        };
        for _ in 0..1000 {
            let sigma = (ssr / chi2.sample(&mut rng)).sqrt();
            if sigma >= group.low && sigma <= group.high {
                return sigma;
            }
        }
        truncated_sigma_tail_draw(ssr, n, group.low, group.high, &mut rng)
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

/// A standard-normal number that is a deterministic function of the bits of `x` and `salt`
/// (hashing, then the Box–Muller transform).
fn hashed_normal(x: &[f64], salt: u64) -> f64 {
    let h = hash_bits(x, salt);
    let u1 = ((h >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    let h2 = hash_bits(&[f64::from_bits(h)], salt ^ 1);
    let u2 = ((h2 >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// SplitMix64 hash of the bits of `x` and `salt`.
fn hash_bits(x: &[f64], salt: u64) -> u64 {
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
    h
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
        // Small fixed scratch on the stack: no allocation on the sampler's hot path.
        let mut f_end = [None; MAX_RUNS];
        let mut sigma_fit = [(0.0, 0usize); MAX_RUNS];
        for &i in &self.order {
            let r = &self.runs[i];
            let obs = &r.data.force;
            let n = r.data.n_obs;
            // Weighted by the points per bin when binned: a bin mean has variance σ²/w.
            let weights = r.data.weights.as_deref();
            let mut ssr = 0.0;
            let mut last = 0.0;
            self.visit_run(x, r, &f_end, |j, f| {
                if j < n {
                    let e = obs[j] - f;
                    ssr += weights.map_or(1.0, |w| w[j]) * e * e;
                }
                last = f;
            })
            .map_err(law_error)?;
            lp += r.data.half_log_weights();
            if r.scene == Scene::First {
                f_end[i] = Some(last);
            }
            match r.sigma {
                SigmaSource::Coord(s) => {
                    let sigma = x[s].exp();
                    lp += -(n as f64) * (sigma.ln() + LN_SQRT_2PI) - 0.5 * ssr / (sigma * sigma);
                }
                SigmaSource::Marginal(g) => {
                    sigma_fit[g].0 += ssr;
                    sigma_fit[g].1 += n;
                }
            }
        }
        for (group, &(ssr, n)) in self.sigma_groups.iter().zip(&sigma_fit) {
            lp += marginal_sigma_log_likelihood(ssr, n, group.low, group.high)
                .ok_or(LogDensityError::rejected(REJECT_PRIOR))?;
        }
        if !derived.is_empty() {
            self.derived_values(x, &sigma_fit[..self.sigma_groups.len()], derived);
        }
        Ok(lp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed form against brute-force integration over ln σ.
    #[test]
    fn marginal_sigma_matches_quadrature() {
        for &(ssr, n, low, high) in &[
            (3.0e-5_f64, 3000usize, 1e-8_f64, 1.0_f64),
            (2.0, 10, 0.1, 10.0),
            // Posterior of σ pressed against the upper bound: the truncation term matters.
            (50.0, 8, 0.01, 1.5),
        ] {
            let ln_range = (high / low).ln();
            let m = 400_000;
            let (a, b) = (low.ln(), high.ln());
            let h = (b - a) / m as f64;
            let log_terms: Vec<f64> = (0..m)
                .map(|i| {
                    let u = a + (i as f64 + 0.5) * h;
                    let sigma = u.exp();
                    -(n as f64) * (sigma.ln() + LN_SQRT_2PI)
                        - 0.5 * ssr / (sigma * sigma)
                        - ln_range.ln()
                })
                .collect();
            let max = log_terms.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let quad = max + (log_terms.iter().map(|t| (t - max).exp()).sum::<f64>() * h).ln();
            let closed = marginal_sigma_log_likelihood(ssr, n, low, high).unwrap();
            assert!(
                (quad - closed).abs() < 1e-6,
                "ssr {ssr} n {n}: quadrature {quad} closed {closed}"
            );
        }
        assert!(marginal_sigma_log_likelihood(0.0, 100, 1e-8, 1.0).is_none());
    }

    /// ln[P(n/2, SSR/(2 low²)) − P(n/2, SSR/(2 high²))] against mpmath at 50 digits
    /// (`mp.log(mp.gammainc(n/2, ssr/(2*high**2), ssr/(2*low**2), regularized=True))`),
    /// in both tails where linear space underflows: residuals far larger than the prior of σ
    /// allows (a start far from the data) and far smaller.
    #[test]
    fn truncation_mass_stays_finite_in_both_tails() {
        for &(ssr, n, low, high, reference) in &[
            (
                1e6_f64,
                100usize,
                1e-8_f64,
                1.0_f64,
                -499_501.569_840_449_f64,
            ),
            (1.0, 201, 3e-5, 3e-4, -5_554_371.725_334_001),
            (0.01, 51, 3e-5, 3e-4, -55_344.278_381_508_29),
            (1e-9, 201, 3e-5, 3e-4, -425.668_325_380_956_4),
            (50.0, 8, 0.01, 1.5, -5.399_151_521_749_207),
            (2.0, 10, 0.1, 10.0, -8.264_185_641_809_913e-13),
        ] {
            let half_ssr = 0.5 * ssr;
            let got = ln_gamma_p_difference(
                0.5 * n as f64,
                half_ssr / (high * high),
                half_ssr / (low * low),
            )
            .unwrap();
            // Relative 1e-10, or 1e-14 absolute where the mass is close to 1 (ln near 0).
            assert!(
                (got - reference).abs() <= 1e-10 * reference.abs() + 1e-14,
                "ssr {ssr} n {n}: {got} vs {reference}"
            );
        }
    }

    /// Far above the prior's bounds the conditional σ piles up just below `high`: the tail
    /// draw matches the exact truncated law there, E[u] ≈ u_h + 1/λ.
    #[test]
    fn sigma_tail_draws_follow_the_truncated_conditional() {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let (ssr, n, low, high) = (1.0, 201usize, 3e-5, 3e-4);
        let (s, u_h) = (100.5, 0.5 / (high * high));
        let m = 20_000;
        let draws: Vec<f64> = (0..m)
            .map(|_| truncated_sigma_tail_draw(ssr, n, low, high, &mut rng))
            .collect();
        assert!(draws.iter().all(|&d| d > low && d <= high));
        let mean_u = draws.iter().map(|d| 0.5 * ssr / (d * d)).sum::<f64>() / m as f64;
        // Truncated Gamma(s) above u_h ≫ s: u − u_h is nearly Exp(λ), λ = 1 − (s − 1)/u_h;
        // the Monte-Carlo error of the mean is about 1/(λ√m).
        let lambda = 1.0 - (s - 1.0) / u_h;
        assert!(
            (mean_u - u_h - 1.0 / lambda).abs() < 5.0 / (lambda * (m as f64).sqrt()),
            "{mean_u} vs {}",
            u_h + 1.0 / lambda
        );
        // Below the bounds: the lower bound.
        assert!((truncated_sigma_tail_draw(1e-12, n, low, high, &mut rng) - low).abs() < 1e-20);
    }

    /// Binned observations: ∫ Πⱼ N(rⱼ | 0, σ²/wⱼ) p(σ) dσ by quadrature equals the closed form
    /// at the weighted sum of squares plus ½ Σ ln wⱼ, as `log_density` adds them.
    #[test]
    fn weighted_marginal_sigma_matches_quadrature() {
        let residuals = [0.3, -1.1, 0.4, 2.0, -0.7, 0.05, 1.3];
        let weights = [10.0, 11.0, 10.0, 3.0, 1.0, 25.0, 7.0];
        let (low, high) = (0.05_f64, 20.0_f64);
        let n = residuals.len();
        let wssr: f64 = residuals.iter().zip(&weights).map(|(r, w)| w * r * r).sum();
        let half_log_w: f64 = 0.5 * weights.iter().map(|w: &f64| w.ln()).sum::<f64>();
        let closed = marginal_sigma_log_likelihood(wssr, n, low, high).unwrap() + half_log_w;
        let m = 400_000;
        let (a, b) = (low.ln(), high.ln());
        let h = (b - a) / m as f64;
        let ln_range = (high / low).ln();
        let terms: Vec<f64> = (0..m)
            .map(|i| {
                let sigma = (a + (i as f64 + 0.5) * h).exp();
                // The density of each bin mean written out, not through the sum of squares.
                residuals
                    .iter()
                    .zip(&weights)
                    .map(|(r, w)| {
                        let sd = sigma / w.sqrt();
                        -sd.ln() - LN_SQRT_2PI - 0.5 * (r / sd).powi(2)
                    })
                    .sum::<f64>()
                    - ln_range.ln()
            })
            .collect();
        let max = terms.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let quad = max + (terms.iter().map(|t| (t - max).exp()).sum::<f64>() * h).ln();
        assert!(
            (quad - closed).abs() < 1e-6,
            "quadrature {quad}, closed {closed}"
        );
    }

    #[test]
    fn hashed_normal_is_standard_normal() {
        let draws: Vec<f64> = (0..20_000).map(|i| hashed_normal(&[i as f64], 7)).collect();
        let mean = draws.iter().sum::<f64>() / draws.len() as f64;
        let var = draws.iter().map(|z| (z - mean).powi(2)).sum::<f64>() / draws.len() as f64;
        // 4 standard errors.
        assert!(mean.abs() < 4.0 / (draws.len() as f64).sqrt(), "{mean}");
        assert!(
            (var - 1.0).abs() < 4.0 * (2.0 / draws.len() as f64).sqrt(),
            "{var}"
        );
    }
}
