//! The seven posteriors, written from posteriordb's Stan programs
//! (`posterior_database/models/stan/*.stan`): the same priors and likelihoods, every
//! constrained parameter sampled through Stan's transform with its log-Jacobian:
//!
//! - `<lower=0>`: x = eᵘ, plus u;
//! - `<lower=L, upper=U>`: x = L + (U − L)·logistic(u), plus ln(U − L) + ln logistic(u) +
//!   ln(1 − logistic(u));
//! - `ordered[2]`: x₁ = u₁, x₂ = x₁ + e^{u₂}, plus u₂.
//!
//! Constants that Stan's `~` drops are dropped here too where they do not depend on the
//! parameters (they cannot change the posterior).
//!
//! Every density writes the constrained parameters as its derived quantities, named as
//! posteriordb names them (`theta[1]`, `mu`, ...), so that they compare directly with the
//! reference draws; the sampled (unconstrained) coordinates are named `u_<name>`.

use serde_json::Value;
use slipbayes::density::{
    BlockLinks, BlockPlan, BlockUpdate, BlockedDensity, CarriedMove, CarryFollowers,
    ExactConditional, LogDensity, LogDensityError, PlannedBlock,
};
use slipbayes::optimize::SearchMap;

use super::ode::{integrate, OdeError, Tolerances};

/// The ODE models' integration tolerances. Stan ran Lotka–Volterra at rtol 1e-5 / atol 1e-3
/// and the one-compartment model at BDF's 1e-6 / 1e-6; these are far tighter, so that the
/// integration error is many orders below the posterior sd of ln z (≈ 0.05) that it could
/// bias. Measured against scipy at rtol 1e-13 (tests/posteriordb.rs): at most 2.5e-9
/// relative, or 2e-10 absolute where a concentration has decayed below the absolute
/// tolerance. The states are O(1–100) (animals in thousands, mg/L), so the absolute tolerance
/// matters only near zero.
pub const ODE_TOL: Tolerances = Tolerances {
    rtol: 1e-9,
    atol: 1e-9,
    max_steps: 20_000,
};

const LN_SQRT_2PI: f64 = 0.918_938_533_204_672_8;

/// ln Normal(x | mean, sd), the whole density.
pub fn ln_normal(x: f64, mean: f64, sd: f64) -> f64 {
    let z = (x - mean) / sd;
    -0.5 * z * z - sd.ln() - LN_SQRT_2PI
}

/// ln Cauchy(x | 0, scale) up to its constant (Stan's `~` form; a half-Cauchy on x > 0 differs
/// by a constant only).
fn ln_cauchy0(x: f64, scale: f64) -> f64 {
    -(x / scale).mul_add(x / scale, 1.0).ln()
}

/// ln(1 + eᵘ), without overflow.
fn softplus(u: f64) -> f64 {
    if u > 0.0 {
        u + (-u).exp().ln_1p()
    } else {
        u.exp().ln_1p()
    }
}

/// Logistic function 1 / (1 + e^{−u}).
fn logistic(u: f64) -> f64 {
    1.0 / (1.0 + (-u).exp())
}

/// ln(a + b) from ln a and ln b.
fn log_add_exp(a: f64, b: f64) -> f64 {
    let m = a.max(b);
    m + ((a - m).exp() + (b - m).exp()).ln()
}

const REJECT_ODE_STEPS: &str = "ode_too_many_steps";
const REJECT_ODE_NOT_FINITE: &str = "ode_not_finite";
const REJECT_NON_POSITIVE: &str = "ode_non_positive_state";

fn ode_rejection(e: OdeError) -> LogDensityError {
    LogDensityError::rejected(match e {
        OdeError::TooManySteps => REJECT_ODE_STEPS,
        OdeError::NotFinite => REJECT_ODE_NOT_FINITE,
    })
}

fn numbers(data: &Value, key: &str) -> Vec<f64> {
    data[key]
        .as_array()
        .unwrap_or_else(|| panic!("data field `{key}` is not an array"))
        .iter()
        .map(|v| {
            v.as_f64()
                .unwrap_or_else(|| panic!("`{key}`: {v} is not a number"))
        })
        .collect()
}

fn number(data: &Value, key: &str) -> f64 {
    data[key]
        .as_f64()
        .unwrap_or_else(|| panic!("data field `{key}` is not a number"))
}

fn indexed(name: &str, n: usize) -> Vec<String> {
    (1..=n).map(|i| format!("{name}[{i}]")).collect()
}

fn unconstrained(names: &[String]) -> Vec<String> {
    names.iter().map(|n| format!("u_{n}")).collect()
}

// ---------------------------------------------------------------------------------------------
// Eight schools (Rubin 1981): y_j ~ Normal(θ_j, σ_j), θ_j ~ Normal(μ, τ), μ ~ Normal(0, 5),
// τ ~ half-Cauchy(0, 5).

/// Prior scales of posteriordb's eight schools.
const MU_SD: f64 = 5.0;
const TAU_SCALE: f64 = 5.0;

/// The eight schools' data.
#[derive(Debug, Clone)]
pub struct Schools {
    y: Vec<f64>,
    sigma: Vec<f64>,
}

impl Schools {
    pub fn from_json(data: &Value) -> Self {
        let (y, sigma) = (numbers(data, "y"), numbers(data, "sigma"));
        assert_eq!(y.len(), sigma.len());
        Self { y, sigma }
    }

    fn derived_names(&self) -> Vec<String> {
        let mut n = indexed("theta", self.y.len());
        n.extend(["mu".to_string(), "tau".to_string()]);
        n
    }

    /// ln p(μ) + ln p(τ) + ln τ (the Jacobian of u = ln τ).
    fn ln_hyperprior(mu: f64, ln_tau: f64) -> f64 {
        ln_normal(mu, 0.0, MU_SD) + ln_cauchy0(ln_tau.exp(), TAU_SCALE) + ln_tau
    }
}

/// `eight_schools_noncentered`: coordinates θ̃_1..θ̃_J, μ, ln τ (Stan's order), θ = μ + τ θ̃.
pub struct EightSchoolsNoncentered(pub Schools);

impl LogDensity for EightSchoolsNoncentered {
    fn dim(&self) -> usize {
        self.0.y.len() + 2
    }
    fn param_names(&self) -> Vec<String> {
        let mut n = unconstrained(&indexed("theta_trans", self.0.y.len()));
        n.extend(["u_mu".to_string(), "u_tau".to_string()]);
        n
    }
    fn derived_names(&self) -> Vec<String> {
        self.0.derived_names()
    }
    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        let j = self.0.y.len();
        let (mu, ln_tau) = (x[j], x[j + 1]);
        let tau = ln_tau.exp();
        let mut lp = Schools::ln_hyperprior(mu, ln_tau);
        for i in 0..j {
            let theta = x[i].mul_add(tau, mu);
            lp += ln_normal(x[i], 0.0, 1.0) + ln_normal(self.0.y[i], theta, self.0.sigma[i]);
            derived[i] = theta;
        }
        derived[j] = mu;
        derived[j + 1] = tau;
        Ok(lp)
    }
}

/// `eight_schools_centered`: coordinates μ, ln τ, θ_1..θ_J. With `population_block`, the
/// population (μ, ln τ) is a block whose conditional given θ is declared (drawn exactly by
/// slice sampling) and whose ensemble moves carry θ along the non-centred map, as the
/// friction model's pooled parameters are (tests/conditional_blocks.rs); without, the density
/// is the bare Stan program, sampled jointly. Either way the mode search and the first walkers
/// use the non-centred coordinates (the centred density has no mode: it grows without bound
/// as τ → 0 with every θ_j = μ).
pub struct EightSchoolsCentered {
    pub schools: Schools,
    pub population_block: bool,
}

impl EightSchoolsCentered {
    fn population(&self, x: &[f64]) -> f64 {
        let (mu, tau) = (x[0], x[1].exp());
        Schools::ln_hyperprior(x[0], x[1])
            + x[2..].iter().map(|&t| ln_normal(t, mu, tau)).sum::<f64>()
    }
    fn members(&self) -> std::ops::Range<usize> {
        2..2 + self.schools.y.len()
    }
}

impl LogDensity for EightSchoolsCentered {
    fn dim(&self) -> usize {
        self.schools.y.len() + 2
    }
    fn param_names(&self) -> Vec<String> {
        let mut n = vec!["u_mu".to_string(), "u_tau".to_string()];
        n.extend(unconstrained(&indexed("theta", self.schools.y.len())));
        n
    }
    fn derived_names(&self) -> Vec<String> {
        self.schools.derived_names()
    }
    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        let j = self.schools.y.len();
        let likelihood: f64 = (0..j)
            .map(|i| ln_normal(self.schools.y[i], x[2 + i], self.schools.sigma[i]))
            .sum();
        derived[..j].copy_from_slice(&x[2..]);
        derived[j] = x[0];
        derived[j + 1] = x[1].exp();
        Ok(self.population(x) + likelihood)
    }
}

/// With the population block, the population (μ, ln τ) is drawn exactly and carries θ; the
/// state is empty (every update evaluates the whole density, which is cheap).
impl BlockedDensity for EightSchoolsCentered {
    fn state_len(&self) -> usize {
        0
    }
    fn log_density_with_state(
        &self,
        x: &[f64],
        derived: &mut [f64],
        _state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        self.log_density(x, derived)
    }
    fn log_density_after_block(
        &self,
        _block: usize,
        x: &[f64],
        derived: &mut [f64],
        _state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        self.log_density(x, derived)
    }
    fn block_plan(&self) -> BlockPlan<'_> {
        let members: Vec<usize> = self.members().collect();
        BlockPlan {
            blocks: vec![
                PlannedBlock {
                    coords: vec![0, 1],
                    links: BlockLinks {
                        given: vec![],
                        followers: members.clone(),
                    },
                    update: BlockUpdate::Exact {
                        conditional: self,
                        carry: Some(CarriedMove {
                            map: self,
                            optional: false,
                        }),
                    },
                    split: None,
                },
                PlannedBlock {
                    coords: members,
                    links: BlockLinks {
                        given: vec![0, 1],
                        followers: vec![],
                    },
                    update: BlockUpdate::Moves { carry: None },
                    split: None,
                },
            ],
        }
    }
}

impl ExactConditional for EightSchoolsCentered {
    fn conditional_log_density(&self, block: usize, x: &[f64]) -> f64 {
        assert_eq!(block, 0, "only the population block is conditional");
        self.population(x)
    }
    fn log_density_after_draw(
        &self,
        _block: usize,
        x: &[f64],
        derived: &mut [f64],
        _state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        self.log_density(x, derived)
    }
}

/// The non-centred map: each θ_j keeps (θ_j − μ)/τ; ln |det J| = J·Δ ln τ.
impl CarryFollowers for EightSchoolsCentered {
    fn carry_followers(&self, _block: usize, from: &[f64], to: &mut [f64]) -> f64 {
        let scale = (to[1] - from[1]).exp();
        for i in self.members() {
            to[i] = scale.mul_add(from[i] - from[0], to[0]);
        }
        self.schools.y.len() as f64 * (to[1] - from[1])
    }
}

/// y = (μ, ln τ, (θ_j − μ)/τ).
impl SearchMap for EightSchoolsCentered {
    fn search_point(&self, x: &[f64], y: &mut [f64]) {
        let tau = x[1].exp();
        y[..2].copy_from_slice(&x[..2]);
        for i in self.members() {
            y[i] = (x[i] - x[0]) / tau;
        }
    }
    fn density_point(&self, y: &[f64], x: &mut [f64]) -> f64 {
        let tau = y[1].exp();
        x[..2].copy_from_slice(&y[..2]);
        for i in self.members() {
            x[i] = y[i].mul_add(tau, y[0]);
        }
        self.schools.y.len() as f64 * y[1]
    }
}

// ---------------------------------------------------------------------------------------------

/// `arK`: an AR(K) series, y_t ~ Normal(α + Σ_k β_k y_{t−k}, σ) for t > K; α, β_k ~
/// Normal(0, 10), σ ~ half-Cauchy(0, 2.5). Coordinates α, β_1..β_K, ln σ.
pub struct ArK {
    k: usize,
    y: Vec<f64>,
}

impl ArK {
    pub fn from_json(data: &Value) -> Self {
        let k = number(data, "K") as usize;
        Self {
            k,
            y: numbers(data, "y"),
        }
    }
    fn names(&self) -> Vec<String> {
        let mut n = vec!["alpha".to_string()];
        n.extend(indexed("beta", self.k));
        n.push("sigma".into());
        n
    }
}

impl LogDensity for ArK {
    fn dim(&self) -> usize {
        self.k + 2
    }
    fn param_names(&self) -> Vec<String> {
        unconstrained(&self.names())
    }
    fn derived_names(&self) -> Vec<String> {
        self.names()
    }
    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        let (alpha, beta, ln_sigma) = (x[0], &x[1..=self.k], x[self.k + 1]);
        let sigma = ln_sigma.exp();
        let mut lp = ln_normal(alpha, 0.0, 10.0)
            + beta.iter().map(|&b| ln_normal(b, 0.0, 10.0)).sum::<f64>()
            + ln_cauchy0(sigma, 2.5)
            + ln_sigma;
        let mut ss = 0.0;
        for t in self.k..self.y.len() {
            let mu = alpha
                + beta
                    .iter()
                    .enumerate()
                    .map(|(k, b)| b * self.y[t - k - 1])
                    .sum::<f64>();
            ss += (self.y[t] - mu).powi(2);
        }
        let n = (self.y.len() - self.k) as f64;
        lp += -0.5 * ss / (sigma * sigma) - n * ln_sigma;
        derived[..=self.k].copy_from_slice(&x[..=self.k]);
        derived[self.k + 1] = sigma;
        Ok(lp)
    }
}

// ---------------------------------------------------------------------------------------------

/// `garch11`: y_t ~ Normal(μ, σ_t), σ_1 given, σ_t² = α₀ + α₁ (y_{t−1} − μ)² + β₁ σ_{t−1}²;
/// flat priors on μ, α₀ > 0, α₁ ∈ (0, 1), β₁ ∈ (0, 1 − α₁). Coordinates μ, ln α₀, logit α₁,
/// logit(β₁ / (1 − α₁)).
pub struct Garch11 {
    y: Vec<f64>,
    sigma1: f64,
}

impl Garch11 {
    pub fn from_json(data: &Value) -> Self {
        Self {
            y: numbers(data, "y"),
            sigma1: number(data, "sigma1"),
        }
    }
    fn names() -> Vec<String> {
        ["mu", "alpha0", "alpha1", "beta1"]
            .map(String::from)
            .to_vec()
    }
}

impl LogDensity for Garch11 {
    fn dim(&self) -> usize {
        4
    }
    fn param_names(&self) -> Vec<String> {
        unconstrained(&Self::names())
    }
    fn derived_names(&self) -> Vec<String> {
        Self::names()
    }
    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        let (mu, u0, u1, u2) = (x[0], x[1], x[2], x[3]);
        let alpha0 = u0.exp();
        let alpha1 = logistic(u1);
        let upper = logistic(-u1); // 1 − α₁, accurate when α₁ is near 1
        let beta1 = upper * logistic(u2);
        // ln|J|: α₀ = e^{u0}; α₁ = logistic(u1); β₁ = (1 − α₁) logistic(u2), whose Jacobian
        // carries ln(1 − α₁) = −softplus(u1).
        let mut lp =
            u0 - softplus(-u1) - softplus(u1) - softplus(u1) - softplus(-u2) - softplus(u2);
        let mut var = self.sigma1 * self.sigma1;
        for (t, &y) in self.y.iter().enumerate() {
            if t > 0 {
                var = alpha0 + alpha1 * (self.y[t - 1] - mu).powi(2) + beta1 * var;
            }
            lp += -0.5 * (y - mu).powi(2) / var - 0.5 * var.ln();
        }
        derived.copy_from_slice(&[mu, alpha0, alpha1, beta1]);
        Ok(lp)
    }
}

// ---------------------------------------------------------------------------------------------

/// `low_dim_gauss_mix`: y_n ~ θ Normal(μ₁, σ₁) + (1 − θ) Normal(μ₂, σ₂), μ ordered,
/// μ_k ~ Normal(0, 2), σ_k ~ half-Normal(0, 2), θ ~ Beta(5, 5). Coordinates μ₁, ln(μ₂ − μ₁),
/// ln σ₁, ln σ₂, logit θ.
pub struct GaussMix {
    y: Vec<f64>,
}

impl GaussMix {
    pub fn from_json(data: &Value) -> Self {
        Self {
            y: numbers(data, "y"),
        }
    }
    fn names() -> Vec<String> {
        ["mu[1]", "mu[2]", "sigma[1]", "sigma[2]", "theta"]
            .map(String::from)
            .to_vec()
    }
}

impl LogDensity for GaussMix {
    fn dim(&self) -> usize {
        5
    }
    fn param_names(&self) -> Vec<String> {
        unconstrained(&Self::names())
    }
    fn derived_names(&self) -> Vec<String> {
        Self::names()
    }
    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        let mu1 = x[0];
        let mu2 = mu1 + x[1].exp();
        let (ln_s1, ln_s2) = (x[2], x[3]);
        let (s1, s2) = (ln_s1.exp(), ln_s2.exp());
        let ln_theta = -softplus(-x[4]);
        let ln_1m_theta = -softplus(x[4]);
        // Jacobians: ordered (+ u₂), two logs, the logit (+ ln θ + ln(1 − θ)).
        let mut lp = x[1] + ln_s1 + ln_s2 + ln_theta + ln_1m_theta;
        lp += ln_normal(s1, 0.0, 2.0) + ln_normal(s2, 0.0, 2.0);
        lp += ln_normal(mu1, 0.0, 2.0) + ln_normal(mu2, 0.0, 2.0);
        lp += 4.0 * ln_theta + 4.0 * ln_1m_theta; // Beta(5, 5) up to its constant
        let (a, b) = (ln_theta - ln_s1, ln_1m_theta - ln_s2);
        let (p1, p2) = (0.5 / (s1 * s1), 0.5 / (s2 * s2));
        lp += self
            .y
            .iter()
            .map(|&y| log_add_exp(a - p1 * (y - mu1).powi(2), b - p2 * (y - mu2).powi(2)))
            .sum::<f64>()
            - self.y.len() as f64 * LN_SQRT_2PI;
        derived.copy_from_slice(&[mu1, mu2, s1, s2, ln_theta.exp()]);
        Ok(lp)
    }
}

// ---------------------------------------------------------------------------------------------

/// `lotka_volterra` on the Hudson's Bay lynx and hare pelts: z' = ((α − β v) u,
/// (−γ + δ u) v) from z_init at t = 0, observed with lognormal error at t = 1..20 and at 0
/// (y_init); θ₁, θ₃ ~ Normal(1, 0.5), θ₂, θ₄ ~ Normal(0.05, 0.05), all > 0; z_init ~
/// LogNormal(ln 10, 1); σ ~ LogNormal(−1, 1). Coordinates the logs of θ₁..θ₄, z_init, σ.
pub struct LotkaVolterra {
    ts: Vec<f64>,
    y_init: [f64; 2],
    /// ln y[n][k].
    ln_y: Vec<[f64; 2]>,
}

impl LotkaVolterra {
    pub fn from_json(data: &Value) -> Self {
        let y_init = numbers(data, "y_init");
        let ln_y = data["y"]
            .as_array()
            .expect("y is an array")
            .iter()
            .map(|row| {
                let r: Vec<f64> = row
                    .as_array()
                    .expect("a row of y")
                    .iter()
                    .map(|v| v.as_f64().expect("a number").ln())
                    .collect();
                [r[0], r[1]]
            })
            .collect();
        Self {
            ts: numbers(data, "ts"),
            y_init: [y_init[0], y_init[1]],
            ln_y,
        }
    }
    fn names() -> Vec<String> {
        let mut n = indexed("theta", 4);
        n.extend(indexed("z_init", 2));
        n.extend(indexed("sigma", 2));
        n
    }

    /// The populations z(t) at `ts` for θ and z_init.
    pub fn solve(
        theta: [f64; 4],
        z_init: [f64; 2],
        ts: &[f64],
        out: &mut [[f64; 2]],
    ) -> Result<super::ode::OdeStats, OdeError> {
        let [alpha, beta, gamma, delta] = theta;
        let rhs =
            |_t: f64, z: &[f64; 2]| [(alpha - beta * z[1]) * z[0], (-gamma + delta * z[0]) * z[1]];
        integrate(rhs, 0.0, z_init, ts, &ODE_TOL, out)
    }
}

/// ln LogNormal(eˣ | m, s) + x (the Jacobian of x = ln of the variable): −(x − m)²/(2s²) up to
/// a constant.
fn ln_lognormal_of_log(x: f64, m: f64, s: f64) -> f64 {
    -0.5 * ((x - m) / s).powi(2)
}

impl LogDensity for LotkaVolterra {
    fn dim(&self) -> usize {
        8
    }
    fn param_names(&self) -> Vec<String> {
        unconstrained(&Self::names())
    }
    fn derived_names(&self) -> Vec<String> {
        Self::names()
    }
    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        let p: Vec<f64> = x.iter().map(|u| u.exp()).collect();
        let theta = [p[0], p[1], p[2], p[3]];
        let z_init = [p[4], p[5]];
        let (ln_sigma, sigma) = ([x[6], x[7]], [p[6], p[7]]);
        // Priors with the Jacobians of the logs.
        let mut lp = ln_normal(theta[0], 1.0, 0.5)
            + ln_normal(theta[2], 1.0, 0.5)
            + ln_normal(theta[1], 0.05, 0.05)
            + ln_normal(theta[3], 0.05, 0.05)
            + x[..4].iter().sum::<f64>();
        lp += ln_lognormal_of_log(x[6], -1.0, 1.0) + ln_lognormal_of_log(x[7], -1.0, 1.0);
        lp +=
            ln_lognormal_of_log(x[4], 10f64.ln(), 1.0) + ln_lognormal_of_log(x[5], 10f64.ln(), 1.0);
        let mut z = vec![[0.0; 2]; self.ts.len()];
        Self::solve(theta, z_init, &self.ts, &mut z).map_err(ode_rejection)?;
        // Lognormal observations, without the −ln y that does not depend on the parameters.
        for k in 0..2 {
            let mut ss = (self.y_init[k].ln() - x[4 + k]).powi(2);
            for (zn, ln_yn) in z.iter().zip(&self.ln_y) {
                if zn[k].is_nan() || zn[k] <= 0.0 {
                    return Err(LogDensityError::rejected(REJECT_NON_POSITIVE));
                }
                ss += (ln_yn[k] - zn[k].ln()).powi(2);
            }
            let n = (self.ts.len() + 1) as f64;
            lp += -0.5 * ss / (sigma[k] * sigma[k]) - n * ln_sigma[k];
        }
        derived.copy_from_slice(&p);
        Ok(lp)
    }
}

// ---------------------------------------------------------------------------------------------

/// `one_comp_mm_elim_abs`: one compartment with first-order absorption of a dose D into a
/// volume V and Michaelis–Menten elimination, C' = e^{−k_a t} D k_a / V − (V_m / V) C /
/// (K_m + C), C(0) = 0; Ĉ_n ~ LogNormal(ln C(t_n), σ); k_a, K_m, V_m, σ ~ half-Cauchy(0, 1).
/// Coordinates the logs of the four.
///
/// Stan's right-hand side switches the dose on for t > 0 only; it differs from this one at the
/// single instant t = 0, which leaves the solution unchanged (and would only cost an
/// integrator steps to resolve a jump that is not there).
pub struct OneComp {
    t0: f64,
    dose_mg: f64,
    volume_l: f64,
    times: Vec<f64>,
    ln_c_hat: Vec<f64>,
}

impl OneComp {
    pub fn from_json(data: &Value) -> Self {
        Self {
            t0: number(data, "t0"),
            dose_mg: number(data, "D"),
            volume_l: number(data, "V"),
            times: numbers(data, "times"),
            ln_c_hat: numbers(data, "C_hat").iter().map(|c| c.ln()).collect(),
        }
    }
    fn names() -> Vec<String> {
        ["k_a", "K_m", "V_m", "sigma"].map(String::from).to_vec()
    }

    /// The concentrations at `times` for (k_a, K_m, V_m), with C(t0) = 0.
    pub fn solve(
        &self,
        k_a: f64,
        k_m: f64,
        v_m: f64,
        times: &[f64],
        out: &mut [[f64; 1]],
    ) -> Result<super::ode::OdeStats, OdeError> {
        let (input, elim) = (self.dose_mg * k_a / self.volume_l, v_m / self.volume_l);
        let rhs = |t: f64, c: &[f64; 1]| [(-k_a * t).exp() * input - elim * c[0] / (k_m + c[0])];
        integrate(rhs, self.t0, [0.0], times, &ODE_TOL, out)
    }
}

impl LogDensity for OneComp {
    fn dim(&self) -> usize {
        4
    }
    fn param_names(&self) -> Vec<String> {
        unconstrained(&Self::names())
    }
    fn derived_names(&self) -> Vec<String> {
        Self::names()
    }
    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        let p: [f64; 4] = std::array::from_fn(|i| x[i].exp());
        let mut lp: f64 =
            p.iter().map(|&v| ln_cauchy0(v, 1.0)).sum::<f64>() + x.iter().sum::<f64>();
        let mut c = vec![[0.0; 1]; self.times.len()];
        self.solve(p[0], p[1], p[2], &self.times, &mut c)
            .map_err(ode_rejection)?;
        let mut ss = 0.0;
        for (cn, ln_hat) in c.iter().zip(&self.ln_c_hat) {
            if cn[0].is_nan() || cn[0] <= 0.0 {
                return Err(LogDensityError::rejected(REJECT_NON_POSITIVE));
            }
            ss += (ln_hat - cn[0].ln()).powi(2);
        }
        lp += -0.5 * ss / (p[3] * p[3]) - self.times.len() as f64 * x[3];
        derived.copy_from_slice(&p);
        Ok(lp)
    }
}
