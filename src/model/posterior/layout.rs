//! The coordinate and column layout: which sampled coordinate each parameter of each run
//! reads, and which reported column (a [`Quantity`]) each value goes to.
//!
//! Every positive parameter θ is sampled as u = ln θ (its prior carries the Jacobian); a pooled
//! ln θ is centred, ln θ ~ Normal(μ_m, s_m) with its material's population μ_m and ln s_m
//! sampled too. A coordinate is named `ln_<name>[<group>]`, its column `<name>[<group>]` in SI
//! units. One coordinate serves every run of its group (material, contact or run, as the
//! model's levels say), created the first time a run of the group asks for it, so the order of
//! the coordinates follows the order of the runs in the model file.

use std::collections::BTreeMap;

use super::likelihood::RunModel;
use crate::density::{Quantity, QuantityKind};
use crate::law::{LawKind, Scene};
use crate::model::data::RunData;
use crate::model::prior::Prior;
use crate::model::spec::{Level, ModelSpec, Param};

/// How a sampled coordinate enters the prior.
#[derive(Debug, Clone)]
pub(super) enum CoordPrior {
    /// u = ln θ with a prior on θ.
    Log(Prior),
    /// A pooled ln θ ~ Normal(x[mu], exp(x[ln_s])): its population's coordinates.
    Population { mu: usize, ln_s: usize },
}

/// One sampled coordinate.
#[derive(Debug, Clone)]
pub(super) struct Coord {
    pub name: String,
    pub prior: CoordPrior,
}

impl Coord {
    /// Whether the coordinate's prior has density at `u`.
    pub(crate) fn prior_contains(&self, u: f64) -> bool {
        match &self.prior {
            CoordPrior::Log(prior) => prior.ln_density(u.exp()) > f64::NEG_INFINITY,
            CoordPrior::Population { .. } => u.is_finite(),
        }
    }
}

/// Where a run's noise level comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum SigmaSource {
    /// A sampled coordinate ln σ.
    Coord(usize),
    /// Integrated out analytically (log-uniform prior): the index of its group.
    Marginal(usize),
}

/// Runs sharing one σ that is integrated out: σ ~ log-uniform on [low, high].
#[derive(Debug, Clone)]
pub(super) struct SigmaGroup {
    pub low: f64,
    pub high: f64,
    /// Salt of the conditional draw reported for σ.
    pub salt: u64,
    /// Its runs, in run order.
    pub runs: Vec<usize>,
}

/// Which value of a run's peak a column reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum PeakField {
    /// F_peak (N).
    Force,
    /// τ_peak, in interface time (s).
    InterfaceTime,
    /// s_peak = v τ_peak (m).
    SlipDistance,
    /// t_peak = τ_peak + F_peak/(kv), in instrument time (s).
    ObservedTime,
    /// μ_s = F_peak / F_N.
    StaticCoefficient,
}

impl PeakField {
    /// The fields every slide with a law reports, with their names and units, in column order
    /// (μ_s follows only where the normal force is known).
    const ALWAYS: [(Self, &'static str, &'static str); 4] = [
        (Self::Force, "F_peak", "N"),
        (Self::InterfaceTime, "tau_peak", "s"),
        (Self::SlipDistance, "s_peak", "m"),
        (Self::ObservedTime, "t_peak", "s"),
    ];
}

/// How the value of a reported column is computed from a draw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Source {
    /// exp of a log-scale coordinate.
    Coord(usize),
    /// σ of a marginalised group, drawn from its conditional posterior.
    Sigma(usize),
    /// a = (a/F_d) · F_d of a contact.
    AContact { ratio: usize, f_d: usize },
    /// a/F_d of a material times its contacts' mean F_d.
    AMaterial(usize),
    /// A field of a run's peak.
    Peak { run: usize, field: PeakField },
    /// Peak of a new contact of a material whose t0 is pooled (the material's index).
    PeakNew(usize),
}

/// The population of a pooled parameter in one material: the coordinates of ln μ_m (its
/// median) and ln s_m.
#[derive(Debug, Clone, Copy)]
pub(super) struct Population {
    pub param: Param,
    pub material: usize,
    pub mu: usize,
    pub ln_s: usize,
}

/// The aging amplitude of a material, when `a` is shared at the material level.
#[derive(Debug, Clone, Copy)]
pub(super) struct MaterialAging {
    /// Coordinate of ln(a/F_d) (`ratio`) or ln a.
    pub coord: usize,
    pub ratio: bool,
}

/// What the derived quantities of a material need.
#[derive(Debug, Clone)]
pub(super) struct MaterialModel {
    pub name: String,
    /// Its aging coordinate, when `a` is a material parameter.
    pub aging: Option<MaterialAging>,
    /// Coordinate of ln α, when α is a material parameter used by some run.
    pub alpha: Option<usize>,
    /// Velocity of its first first slide: where a new contact's peak is predicted.
    pub slow_velocity: Option<f64>,
}

/// The complete layout of a posterior.
#[derive(Debug, Clone)]
pub(super) struct Layout {
    pub coords: Vec<Coord>,
    pub quantities: Vec<Quantity>,
    /// How each column of `quantities` is computed.
    pub sources: Vec<Source>,
    pub runs: Vec<RunModel>,
    pub sigma_groups: Vec<SigmaGroup>,
    pub populations: Vec<Population>,
    pub materials: Vec<MaterialModel>,
    /// Per contact: the coordinate of ln F_d (`None` where no run of it uses F_d).
    pub contact_fd: Vec<Option<usize>>,
}

impl Layout {
    /// Lays out the coordinates and columns of `spec` over its runs' `data` (one per run, in
    /// model order).
    pub fn new(spec: &ModelSpec, data: Vec<RunData>) -> Self {
        let mut b = Builder::new(spec);
        let runs: Vec<RunModel> = data
            .into_iter()
            .enumerate()
            .map(|(i, d)| b.run(i, d))
            .collect();
        let contact_fd = contact_fd(spec, &runs);
        b.contact_a_columns(&runs);
        let materials = b.materials(&runs);
        b.material_a_columns(&materials);
        b.peak_columns(&runs);
        b.new_contact_columns(&materials);
        Self {
            coords: b.coords,
            quantities: b.quantities,
            sources: b.sources,
            runs,
            sigma_groups: b.sigma_groups,
            populations: b.populations,
            materials,
            contact_fd,
        }
    }
}

/// Per contact, the coordinate of ln F_d its runs read.
fn contact_fd(spec: &ModelSpec, runs: &[RunModel]) -> Vec<Option<usize>> {
    let mut out = vec![None; spec.file.contacts.len()];
    for r in runs {
        if r.f_d.is_some() {
            out[r.contact] = r.f_d;
        }
    }
    out
}

/// The group (level, index) run `run` belongs to at `level`.
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

/// Builds the layout run by run.
struct Builder<'a> {
    spec: &'a ModelSpec,
    /// `a` is sampled as a/F_d (`aging = "ratio"` under a law with F_d).
    ratio: bool,
    /// The law of first and fast slides.
    law: LawKind,
    coords: Vec<Coord>,
    quantities: Vec<Quantity>,
    sources: Vec<Source>,
    /// (parameter, level, group) → coordinate.
    index: BTreeMap<(Param, Level, usize), usize>,
    /// (level, group) → marginalised σ group.
    sigma_index: BTreeMap<(Level, usize), usize>,
    sigma_groups: Vec<SigmaGroup>,
    populations: Vec<Population>,
}

impl<'a> Builder<'a> {
    fn new(spec: &'a ModelSpec) -> Self {
        Self {
            spec,
            ratio: spec.forward().aging_ratio(spec.file.aging),
            law: spec.file.law,
            coords: Vec::new(),
            quantities: Vec::new(),
            sources: Vec::new(),
            index: BTreeMap::new(),
            sigma_index: BTreeMap::new(),
            sigma_groups: Vec::new(),
            populations: Vec::new(),
        }
    }

    fn column(&mut self, name: &str, group: String, unit: &str, kind: QuantityKind, src: Source) {
        self.quantities.push(Quantity {
            column: format!("{name}[{group}]"),
            name: name.to_owned(),
            group,
            unit: unit.to_owned(),
            kind,
        });
        self.sources.push(src);
    }

    /// A new sampled coordinate and its parameter column; returns the coordinate.
    fn coordinate(
        &mut self,
        coord: String,
        prior: CoordPrior,
        name: &str,
        group: String,
        unit: &str,
    ) -> usize {
        self.coords.push(Coord { name: coord, prior });
        let i = self.coords.len() - 1;
        self.column(name, group, unit, QuantityKind::Parameter, Source::Coord(i));
        i
    }

    /// The coordinate of parameter `p` for run `run`, created with the first run of its group.
    fn shared(&mut self, p: Param, run: usize) -> usize {
        let (level, g) = group_of(self.spec, self.spec.level(p), run);
        if let Some(&i) = self.index.get(&(p, level, g)) {
            return i;
        }
        let group = group_name(self.spec, level, g);
        let (name, unit) = if p == Param::A && self.ratio {
            ("a_over_F_d", "1")
        } else {
            (p.name(), p.unit())
        };
        let prior = if self.spec.file.pooling.pools(p) {
            let material = self.spec.contact_material[self.spec.run_contact[run]];
            let pop = self.population(p, material, name, unit);
            CoordPrior::Population {
                mu: pop.mu,
                ln_s: pop.ln_s,
            }
        } else {
            CoordPrior::Log(self.spec.prior(name))
        };
        let i = self.coordinate(format!("ln_{name}[{group}]"), prior, name, group, unit);
        self.index.insert((p, level, g), i);
        i
    }

    /// The population of parameter `param` (reported as `name`, in `unit`) in `material`,
    /// created with its first pooled member.
    fn population(&mut self, param: Param, material: usize, name: &str, unit: &str) -> Population {
        if let Some(p) = self
            .populations
            .iter()
            .find(|p| p.param == param && p.material == material)
        {
            return *p;
        }
        let m = self.spec.file.materials[material].name.clone();
        let (median, log_sd) = (format!("{name}_pop_median"), format!("{name}_pop_log_sd"));
        let prior = CoordPrior::Log(self.spec.prior(&median));
        let mu = self.coordinate(format!("ln_{median}[{m}]"), prior, &median, m.clone(), unit);
        let prior = CoordPrior::Log(self.spec.prior(&log_sd));
        let ln_s = self.coordinate(format!("ln_{log_sd}[{m}]"), prior, &log_sd, m, "1");
        let p = Population {
            param,
            material,
            mu,
            ln_s,
        };
        self.populations.push(p);
        p
    }

    /// σ of run `run`: integrated out when its prior is log-uniform (one dimension less per
    /// σ), else a sampled coordinate.
    fn sigma(&mut self, run: usize) -> SigmaSource {
        let Prior::LogUniform { low, high } = self.spec.prior("sigma") else {
            return SigmaSource::Coord(self.shared(Param::Sigma, run));
        };
        let (level, g) = group_of(self.spec, self.spec.level(Param::Sigma), run);
        if let Some(&k) = self.sigma_index.get(&(level, g)) {
            self.sigma_groups[k].runs.push(run);
            return SigmaSource::Marginal(k);
        }
        let k = self.sigma_groups.len();
        self.sigma_index.insert((level, g), k);
        self.sigma_groups.push(SigmaGroup {
            low,
            high,
            salt: 0x5165_0000 + k as u64,
            runs: vec![run],
        });
        let group = group_name(self.spec, level, g);
        self.column(
            "sigma",
            group,
            "N",
            QuantityKind::Parameter,
            Source::Sigma(k),
        );
        SigmaSource::Marginal(k)
    }

    /// Run `i` with its data: the coordinates of the parameters its scene uses under the
    /// model's forward model, in the order α, a, b, D_c, F_d, t0, k, σ ("model only what a
    /// scene needs").
    fn run(&mut self, i: usize, data: RunData) -> RunModel {
        let spec = self.spec;
        let run = &spec.file.runs[i];
        let scene = run.scene;
        let uses = |p: Param| spec.uses(p, i);
        let alpha = uses(Param::Alpha).then(|| self.shared(Param::Alpha, i));
        let a = uses(Param::A).then(|| self.shared(Param::A, i));
        let b = uses(Param::B).then(|| self.shared(Param::B, i));
        let d_c = uses(Param::Dc).then(|| self.shared(Param::Dc, i));
        let f_d = uses(Param::FD).then(|| self.shared(Param::FD, i));
        let t0 = uses(Param::T0).then(|| self.shared(Param::T0, i));
        let k = uses(Param::K).then(|| self.shared(Param::K, i));
        let sigma = self.sigma(i);
        let contact = spec.run_contact[i];
        let normal_force = spec.file.contacts[contact]
            .normal_force_n
            .or(data.mean_normal_force());
        RunModel {
            name: run.name.clone(),
            scene,
            law: self.law,
            velocity: run.velocity_m_per_s,
            data,
            contact,
            alpha,
            a,
            ratio: self.ratio,
            b,
            d_c,
            state_law: spec.forward().state_law,
            reference_velocity: spec.file.reference_velocity_m_per_s,
            f_d,
            t0,
            k,
            sigma,
            follows: spec.run_follows[i],
            normal_force,
            reduction: None,
            held: true,
        }
    }

    /// With `aging = "ratio"`, a = (a/F_d)·F_d of every contact whose runs use it.
    fn contact_a_columns(&mut self, runs: &[RunModel]) {
        if !self.ratio {
            return;
        }
        let mut seen = vec![false; self.spec.file.contacts.len()];
        for r in runs {
            let (Some(ratio), Some(f_d)) = (r.a, r.f_d) else {
                continue;
            };
            if seen[r.contact] {
                continue;
            }
            seen[r.contact] = true;
            let c = self.spec.file.contacts[r.contact].name.clone();
            let source = Source::AContact { ratio, f_d };
            self.column("a", c, "N", QuantityKind::Parameter, source);
        }
    }

    /// What each material's derived quantities need.
    fn materials(&self, runs: &[RunModel]) -> Vec<MaterialModel> {
        let spec = self.spec;
        let mut out: Vec<MaterialModel> = spec
            .file
            .materials
            .iter()
            .map(|m| MaterialModel {
                name: m.name.clone(),
                aging: None,
                alpha: None,
                slow_velocity: None,
            })
            .collect();
        for r in runs {
            let m = &mut out[spec.contact_material[r.contact]];
            if let Some(coord) = r.a {
                if spec.level(Param::A) == Level::Material {
                    m.aging = Some(MaterialAging {
                        coord,
                        ratio: r.ratio,
                    });
                }
            }
            if m.alpha.is_none() {
                m.alpha = r.alpha;
            }
            if r.scene == Scene::First && m.slow_velocity.is_none() {
                m.slow_velocity = Some(r.velocity);
            }
        }
        out
    }

    /// With `aging = "ratio"` at the material level, a[material] = (a/F_d) × the mean F_d of
    /// its contacts.
    fn material_a_columns(&mut self, materials: &[MaterialModel]) {
        for (m, material) in materials.iter().enumerate() {
            if material.aging.is_some_and(|a| a.ratio) {
                let name = material.name.clone();
                self.column("a", name, "N", QuantityKind::Derived, Source::AMaterial(m));
            }
        }
    }

    /// The peak of every slide with a law that has one: F_peak, τ_peak, s_peak, t_peak, and
    /// μ_s where the normal force is known.
    fn peak_columns(&mut self, runs: &[RunModel]) {
        for (run, r) in runs.iter().enumerate() {
            if r.scene == Scene::Repeat || !r.law.has_peak() {
                continue;
            }
            for (field, name, unit) in PeakField::ALWAYS {
                let source = Source::Peak { run, field };
                self.column(name, r.name.clone(), unit, QuantityKind::Derived, source);
            }
            if r.normal_force.is_some() {
                let source = Source::Peak {
                    run,
                    field: PeakField::StaticCoefficient,
                };
                self.column("mu_s", r.name.clone(), "1", QuantityKind::Derived, source);
            }
        }
    }

    /// The peak of a new contact of each material whose t0 is pooled, that has an aging
    /// amplitude (shared or pooled) and a slow slide to predict it at, under a law with a
    /// peak.
    fn new_contact_columns(&mut self, materials: &[MaterialModel]) {
        let pooled = |param: Param, m: usize| {
            self.populations
                .iter()
                .any(|p| p.param == param && p.material == m)
        };
        let predicted: Vec<usize> = (0..materials.len())
            .filter(|&m| {
                let material = &materials[m];
                self.law.has_peak()
                    && pooled(Param::T0, m)
                    && (material.aging.is_some() || pooled(Param::A, m))
                    && material.slow_velocity.is_some()
            })
            .collect();
        for m in predicted {
            let name = materials[m].name.clone();
            let source = Source::PeakNew(m);
            self.column("F_peak_new", name, "N", QuantityKind::Derived, source);
        }
    }
}
