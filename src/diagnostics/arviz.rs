//! ArviZ's convergence diagnostics (arviz 0.23 `rhat`, `ess`, `mcse`, `hdi`), reproduced
//! operation for operation so that the numbers agree to rounding.
//!
//! `chains[c]` is chain `c`'s draws, all chains the same length. As in ArviZ every statistic
//! except the plain Geyer ESS works on *split* chains (first and last `n/2` draws, the middle
//! draw dropped when `n` is odd), ranks are average ranks over all draws, and the normal scores
//! use Blom's offset 3/8. Where ArviZ returns NaN for too little input these functions return a
//! [`DiagnosticsError`]; R-hat of draws that are all equal is NaN, as in ArviZ (it is undefined).

use std::borrow::Cow;

use rustfft::{num_complex::Complex, FftPlanner};

use super::error::{check_prob, validate_chains, DiagnosticsError};
use crate::special::{beta_ppf, norm_ppf};

/// Fewest draws per chain for R-hat, ESS and MCSE (ArviZ's `min_draws = 4`).
pub const MIN_DRAWS: usize = 4;
/// Fewest chains for R-hat (ArviZ's `min_chains = 2`).
pub const MIN_CHAINS_RHAT: usize = 2;
/// Probabilities of the two quantile indicators whose smaller ESS is the tail ESS.
pub const TAIL_PROBS: (f64, f64) = (0.05, 0.95);
/// ArviZ's `np.finfo(float).resolution`: draws spanning less than this count as constant and
/// get ESS = number of draws.
const CONSTANT_RANGE: f64 = 1e-15;
/// Blom's fractional offset for normal scores of ranks.
const BLOM_C: f64 = 3.0 / 8.0;
/// Beta probabilities at minus and plus one standard deviation used by ArviZ's quantile MCSE.
const MCSE_QUANTILE_PROBS: [f64; 2] = [0.158_655_3, 0.841_344_7];

/// Rows of equal length stored flat, row-major: chains (or split half-chains) by draws.
#[derive(Debug, Clone)]
pub(crate) struct Mat<'a> {
    pub(crate) rows: usize,
    pub(crate) cols: usize,
    /// Borrowed when the draws are already laid out row by row, so that the diagnostics of a
    /// long run make no copy of them.
    pub(crate) data: Cow<'a, [f64]>,
}

impl Mat<'_> {
    pub(crate) fn from_chains(chains: &[&[f64]]) -> Self {
        let cols = chains.first().map_or(0, |c| c.len());
        let data: Vec<f64> = chains.iter().flat_map(|c| c.iter().copied()).collect();
        Mat {
            rows: chains.len(),
            cols,
            data: data.into(),
        }
    }

    pub(crate) fn row(&self, r: usize) -> &[f64] {
        &self.data[r * self.cols..(r + 1) * self.cols]
    }

    fn map(&self, f: impl Fn(f64) -> f64) -> Mat<'static> {
        Mat {
            rows: self.rows,
            cols: self.cols,
            data: self.data.iter().map(|&v| f(v)).collect::<Vec<_>>().into(),
        }
    }

    /// ArviZ `_split_chains`: the first `n/2` draws of every chain, then the last `n/2`.
    pub(crate) fn split(&self) -> Mat<'static> {
        let half = self.cols / 2;
        let mut data = Vec::with_capacity(2 * self.rows * half);
        for r in 0..self.rows {
            data.extend_from_slice(&self.row(r)[..half]);
        }
        for r in 0..self.rows {
            data.extend_from_slice(&self.row(r)[self.cols - half..]);
        }
        Mat {
            rows: 2 * self.rows,
            cols: half,
            data: data.into(),
        }
    }
}

/// Arithmetic mean in index order (numpy uses pairwise summation; the difference is rounding).
pub(crate) fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Two-pass variance with `ddof` degrees of freedom removed, as `np.var`.
pub(crate) fn var(x: &[f64], ddof: usize) -> f64 {
    let m = mean(x);
    x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - ddof) as f64
}

/// Values sorted ascending (inputs are validated finite, so `total_cmp` is the usual order).
pub(crate) fn sorted(x: &[f64]) -> Vec<f64> {
    let mut s = x.to_vec();
    s.sort_by(f64::total_cmp);
    s
}

/// `np.median`: the middle value, or the mean of the two middle values.
pub(crate) fn median_of_sorted(s: &[f64]) -> f64 {
    median_at(s.len(), &|i| s[i])
}

/// [`median_of_sorted`] of `n` sorted values, the `i`-th given by `at(i)`: what a summary
/// whose sorted draws are not in memory asks for (see [`super::external`]).
pub(crate) fn median_at(n: usize, at: &dyn Fn(usize) -> f64) -> f64 {
    if n % 2 == 1 {
        at(n / 2)
    } else {
        (at(n / 2 - 1) + at(n / 2)) / 2.0
    }
}

/// Sum in index order from -0.0, as `Iterator::sum` of f64 takes it: a sum fed in pieces
/// (a row read in segments, a column in row groups) equals `.sum()` of the whole to the bit.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SeqSum(pub(crate) f64);

impl Default for SeqSum {
    fn default() -> Self {
        Self(-0.0)
    }
}

impl SeqSum {
    pub(crate) fn add_all(&mut self, x: impl IntoIterator<Item = f64>) {
        for v in x {
            self.0 += v;
        }
    }
}

/// Normal scores of average ranks (1-based, ties share the mean rank, as
/// `scipy.stats.rankdata`): `idx` lists the draws `0..idx.len()` in ascending order of their
/// values `x(i)`, and `z[i]` receives the score of draw `i`.
fn fill_scores(idx: &[u32], x: impl Fn(usize) -> f64, z: &mut [f64]) {
    let size = idx.len() as f64;
    let mut start = 0;
    while start < idx.len() {
        let mut end = start + 1;
        let first = x(idx[start] as usize);
        // partial_cmp treats -0.0 and 0.0 as tied, as numpy does.
        while end < idx.len()
            && x(idx[end] as usize).partial_cmp(&first) == Some(std::cmp::Ordering::Equal)
        {
            end += 1;
        }
        let score = normal_score(average_rank(start, end), size);
        for &i in &idx[start..end] {
            z[i as usize] = score;
        }
        start = end;
    }
}

/// The draws `0..n` in ascending order of `x(i)` (u32 indices halve the working memory of
/// the largest copy; chains of 2^32 draws of one quantity are beyond any run).
fn order_by(n: usize, x: impl Fn(usize) -> f64) -> Vec<u32> {
    let mut idx: Vec<u32> = (0..n as u32).collect();
    idx.sort_by(|&a, &b| x(a as usize).total_cmp(&x(b as usize)));
    idx
}

/// The average rank (1-based) of the sorted positions `start..end` (0-based, `end`
/// excluded) that hold equal values.
pub(crate) fn average_rank(start: usize, end: usize) -> f64 {
    0.5 * ((start + 1) as f64 + end as f64)
}

/// The normal score of average rank `r` among `size` draws (Blom's offset).
pub(crate) fn normal_score(r: f64, size: f64) -> f64 {
    norm_ppf((r - BLOM_C) / (size - 2.0 * BLOM_C + 1.0))
}

/// ArviZ `_z_scale`: normal scores of the pooled average ranks.
pub(crate) fn z_scale(m: &Mat) -> Mat<'static> {
    let mut data = vec![0.0; m.data.len()];
    fill_scores(
        &order_by(m.data.len(), |i| m.data[i]),
        |i| m.data[i],
        &mut data,
    );
    Mat {
        rows: m.rows,
        cols: m.cols,
        data: data.into(),
    }
}

/// ArviZ `_rhat`: the classic potential scale reduction of the rows of `m`.
pub(crate) fn rhat_raw(m: &Mat) -> f64 {
    let mut rows = RhatRows::new(m.cols);
    for r in 0..m.rows {
        let row = m.row(r);
        let mu = mean(row);
        rows.push(mu, var_about(row, mu, 1));
    }
    rows.finish()
}

/// `np.var` about a given mean `m` (the mean of `x`).
fn var_about(x: &[f64], m: f64, ddof: usize) -> f64 {
    x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - ddof) as f64
}

/// [`rhat_raw`] fed one row's mean and variance (`ddof = 1`) at a time, in row order.
#[derive(Debug, Clone)]
pub(crate) struct RhatRows {
    cols: usize,
    means: Vec<f64>,
    vars: Vec<f64>,
}

impl RhatRows {
    pub(crate) fn new(cols: usize) -> Self {
        Self {
            cols,
            means: Vec::new(),
            vars: Vec::new(),
        }
    }

    pub(crate) fn push(&mut self, mean: f64, var: f64) {
        self.means.push(mean);
        self.vars.push(var);
    }

    pub(crate) fn finish(self) -> f64 {
        let n = self.cols as f64;
        let between = n * var(&self.means, 1);
        let within = mean(&self.vars);
        ((between / within + n - 1.0) / n).sqrt()
    }
}

/// The smallest 2^a·3^b·5^c at or above `n`: the length ArviZ's `autocov` pads to
/// (`scipy.fftpack.next_fast_len`). rustfft transforms such a length by small radices; a
/// length with a large prime factor (2 × 191 for the split halves of 382 kept steps) goes
/// through Rader's algorithm, at several times the cost.
fn next_fast_len(n: usize) -> usize {
    let n = n.max(1);
    let mut best = n.next_power_of_two();
    let mut p5 = 1;
    while p5 < best {
        let mut p35 = p5;
        while p35 < best {
            let mut m = p35;
            while m < n {
                m *= 2;
            }
            best = best.min(m);
            p35 *= 3;
        }
        p5 *= 5;
    }
    best
}

/// Autocovariances of one row at lags `0..cols` (biased, divided by `cols`), by FFT of the
/// mean-subtracted row zero-padded to [`next_fast_len`]`(2 cols)` (ArviZ `autocov`; any
/// padding of at least `2 cols - 1` gives the same linear autocovariance up to rounding). One
/// plan serves every row of a length.
pub(crate) struct Autocov {
    n: usize,
    fft: std::sync::Arc<dyn rustfft::Fft<f64>>,
    ifft: std::sync::Arc<dyn rustfft::Fft<f64>>,
    buf: Vec<Complex<f64>>,
}

impl Autocov {
    pub(crate) fn new(n: usize) -> Self {
        let len = next_fast_len(2 * n);
        let mut planner = FftPlanner::<f64>::new();
        Self {
            n,
            fft: planner.plan_fft_forward(len),
            ifft: planner.plan_fft_inverse(len),
            buf: vec![Complex::new(0.0, 0.0); len],
        }
    }

    /// The row's mean; `add(t, acov_t)` receives the autocovariance at every lag in order.
    fn of(&mut self, row: &[f64], mut add: impl FnMut(usize, f64)) -> f64 {
        let (n, len) = (self.n, self.buf.len());
        let mu = mean(row);
        for (b, &v) in self.buf.iter_mut().zip(row) {
            *b = Complex::new(v - mu, 0.0);
        }
        for b in self.buf.iter_mut().skip(n) {
            *b = Complex::new(0.0, 0.0);
        }
        self.fft.process(&mut self.buf);
        for b in self.buf.iter_mut() {
            *b = Complex::new(b.norm_sqr(), 0.0);
        }
        self.ifft.process(&mut self.buf);
        // rustfft's inverse is unnormalised: divide by the FFT length, then by n.
        for (t, b) in self.buf[..n].iter().enumerate() {
            add(t, b.re / len as f64 / n as f64);
        }
        mu
    }
}

/// ArviZ `_ess`: multi-chain effective sample size with Geyer's initial positive and initial
/// monotone sequences (Vehtari et al. 2021, eq. 10-11), rows of `m` as chains.
pub(crate) fn ess_raw(m: &Mat) -> f64 {
    let mut autocov = Autocov::new(m.cols);
    let mut rows = EssRows::new(m.cols);
    for r in 0..m.rows {
        rows.push(m.row(r), &mut autocov);
    }
    rows.finish()
}

/// [`ess_raw`] fed one row (chain) at a time, in row order: it keeps the sum of the rows'
/// autocovariances per lag and the rows' means, never the rows, so that its memory is one
/// row's length whatever the number of rows.
#[derive(Debug, Clone)]
pub(crate) struct EssRows {
    n_draw: usize,
    /// Per lag, the autocovariances of the rows so far summed in row order (from -0.0, as
    /// `.sum()` over the rows would).
    acov_sum: Vec<f64>,
    chain_means: Vec<f64>,
    lo: f64,
    hi: f64,
    values: usize,
}

impl EssRows {
    pub(crate) fn new(n_draw: usize) -> Self {
        Self {
            n_draw,
            acov_sum: vec![-0.0; n_draw],
            chain_means: Vec::new(),
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
            values: 0,
        }
    }

    /// Adds the next row (`n_draw` values).
    pub(crate) fn push(&mut self, row: &[f64], autocov: &mut Autocov) {
        debug_assert_eq!(row.len(), self.n_draw);
        let (lo, hi) = row
            .iter()
            .fold((self.lo, self.hi), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        (self.lo, self.hi) = (lo, hi);
        self.values += row.len();
        let sum = &mut self.acov_sum;
        let mu = autocov.of(row, |t, a| sum[t] += a);
        self.chain_means.push(mu);
    }

    pub(crate) fn finish(self) -> f64 {
        if self.hi - self.lo < CONSTANT_RANGE {
            return self.values as f64;
        }
        let n_chain = self.chain_means.len();
        let n_draw = self.n_draw;
        let nd = n_draw as f64;
        let mean_acov = |t: usize| self.acov_sum[t] / n_chain as f64;
        let chain_means = &self.chain_means;
        let mean_var = mean_acov(0) * nd / (nd - 1.0);
        let mut var_plus = mean_var * (nd - 1.0) / nd;
        if n_chain > 1 {
            var_plus += var(chain_means, 1);
        }

        let mut rho = vec![0.0; n_draw];
        let mut rho_even = 1.0;
        rho[0] = rho_even;
        let mut rho_odd = 1.0 - (mean_var - mean_acov(1)) / var_plus;
        rho[1] = rho_odd;

        // Geyer's initial positive sequence. Indices are signed because ArviZ's max_t can be
        // -1.
        let mut t: isize = 1;
        while t < n_draw as isize - 3 && rho_even + rho_odd > 0.0 {
            let tu = t as usize;
            rho_even = 1.0 - (mean_var - mean_acov(tu + 1)) / var_plus;
            rho_odd = 1.0 - (mean_var - mean_acov(tu + 2)) / var_plus;
            if rho_even + rho_odd >= 0.0 {
                rho[tu + 1] = rho_even;
                rho[tu + 2] = rho_odd;
            }
            t += 2;
        }
        let max_t = t - 2;
        if rho_even > 0.0 {
            rho[(max_t + 1) as usize] = rho_even;
        }
        // Geyer's initial monotone sequence.
        let mut t: isize = 1;
        while t <= max_t - 2 {
            let tu = t as usize;
            if rho[tu + 1] + rho[tu + 2] > rho[tu - 1] + rho[tu] {
                rho[tu + 1] = (rho[tu - 1] + rho[tu]) / 2.0;
                rho[tu + 2] = rho[tu + 1];
            }
            t += 2;
        }
        let ess = (n_chain * n_draw) as f64;
        let head: f64 = rho[..(max_t + 1) as usize].iter().sum();
        let next = rho.get((max_t + 1) as usize).copied().unwrap_or(0.0);
        let tau_hat = (-1.0 + 2.0 * head + next).max(1.0 / ess.log10());
        if rho.iter().any(|v| v.is_nan()) {
            return f64::NAN;
        }
        ess / tau_hat
    }
}

/// Quantile by Hyndman and Fan's type 7 with scipy `mquantiles(alphap=1, betap=1)` arithmetic
/// (what ArviZ uses for the tail and quantile indicators).
fn mquantile_sorted(s: &[f64], p: f64) -> f64 {
    mquantile_at(s.len(), &|i| s[i], p)
}

/// [`mquantile_sorted`] of `n` sorted values given by `at`.
pub(crate) fn mquantile_at(n: usize, at: &dyn Fn(usize) -> f64, p: f64) -> f64 {
    if n == 1 {
        return at(0);
    }
    let nf = n as f64;
    // m = alphap + p (1 - alphap - betap) = 1 - p
    let aleph = nf * p + (1.0 - p);
    let k = aleph.clamp(1.0, nf - 1.0).floor();
    let gamma = (aleph - k).clamp(0.0, 1.0);
    let k = k as usize;
    (1.0 - gamma) * at(k - 1) + gamma * at(k)
}

/// ESS of the indicator `draw <= q_p` (ArviZ `_ess_quantile`), on split chains.
pub(crate) fn ess_quantile_mat(m: &Mat, p: f64) -> f64 {
    let q = mquantile_sorted(&sorted(&m.data), p);
    ess_raw(&m.map(|v| if v <= q { 1.0 } else { 0.0 }).split())
}

/// Rank-normalised split R-hat of `m` (ArviZ `_rhat_rank`): the larger of the bulk R-hat
/// (normal scores of the draws) and the tail R-hat (normal scores of the draws folded about
/// their median).
pub(crate) fn rhat_rank_mat(m: &Mat) -> f64 {
    rhat_rank_of_split(&m.split())
}

/// As [`rhat_rank_mat`] for rows that are already the split half-chains.
pub(crate) fn rhat_rank_of_split(split: &Mat) -> f64 {
    let bulk = rhat_raw(&z_scale(split));
    let med = median_of_sorted(&sorted(&split.data));
    let tail = rhat_raw(&z_scale(&split.map(|v| (v - med).abs())));
    // ArviZ uses Python's max(): NaN if the first is NaN.
    if bulk.is_nan() || tail.is_nan() {
        f64::NAN
    } else {
        bulk.max(tail)
    }
}

pub(crate) fn ess_bulk_mat(m: &Mat) -> f64 {
    ess_raw(&z_scale(&m.split()))
}

pub(crate) fn ess_tail_mat(m: &Mat) -> f64 {
    ess_quantile_mat(m, TAIL_PROBS.0).min(ess_quantile_mat(m, TAIL_PROBS.1))
}

pub(crate) fn ess_mean_mat(m: &Mat) -> f64 {
    ess_raw(&m.split())
}

pub(crate) fn mcse_mean_mat(m: &Mat) -> f64 {
    var(&m.data, 1).sqrt() / ess_mean_mat(m).sqrt()
}

pub(crate) fn mcse_sd_mat(m: &Mat) -> f64 {
    let mu = mean(&m.data);
    let sims_c2 = m.map(|v| (v - mu) * (v - mu));
    let ess = ess_mean_mat(&sims_c2);
    let evar = mean(&sims_c2.data);
    let mean_sq = sims_c2.data.iter().map(|v| v * v).sum::<f64>() / sims_c2.data.len() as f64;
    let varvar = (mean_sq - evar * evar) / ess;
    (varvar / evar / 4.0).sqrt()
}

pub(crate) fn mcse_quantile_mat(m: &Mat, prob: f64) -> f64 {
    let ess = ess_quantile_mat(m, prob);
    let a = ess * prob + 1.0;
    let b = ess * (1.0 - prob) + 1.0;
    let s = sorted(&m.data);
    let size = s.len() as f64;
    let lo = (beta_ppf(MCSE_QUANTILE_PROBS[0], a, b) * size - 1.0).max(0.0);
    let hi = (beta_ppf(MCSE_QUANTILE_PROBS[1], a, b) * size - 1.0).min(size - 1.0);
    let th1 = s[lo.floor() as usize];
    let th2 = s[hi.ceil() as usize];
    (th2 - th1) / 2.0
}

fn checked(chains: &[&[f64]], what: &'static str) -> Result<Mat<'static>, DiagnosticsError> {
    validate_chains(chains, MIN_DRAWS, what)?;
    Ok(Mat::from_chains(chains))
}

/// Rank-normalised split R-hat, the larger of bulk and folded-tail R-hat (ArviZ
/// `rhat(method="rank")`, Vehtari et al. 2021). NaN when all draws are equal.
///
/// # Errors
/// Fewer than [`MIN_CHAINS_RHAT`] chains or [`MIN_DRAWS`] draws, ragged or non-finite input.
pub fn rhat(chains: &[&[f64]]) -> Result<f64, DiagnosticsError> {
    let m = checked(chains, "R-hat")?;
    if m.rows < MIN_CHAINS_RHAT {
        return Err(DiagnosticsError::TooFewChains {
            what: "R-hat",
            have: m.rows,
            needed: MIN_CHAINS_RHAT,
        });
    }
    Ok(rhat_rank_mat(&m))
}

/// [`rhat`] of `chains` chains of `draws` draws each, draw `t` of chain `c` being
/// `at(c, t)`: the same number to the bit, from the draws where they are. It holds 12 bytes
/// per draw (their order and one score each) where [`rhat`] holds several copies of the
/// draws: what the sampler's stopping rule uses on its history.
///
/// # Errors
/// As [`rhat`].
pub(crate) fn rhat_by(
    chains: usize,
    draws: usize,
    at: &dyn Fn(usize, usize) -> f64,
) -> Result<f64, DiagnosticsError> {
    if chains == 0 {
        return Err(DiagnosticsError::NoChains { needed: 1 });
    }
    if draws < MIN_DRAWS {
        return Err(DiagnosticsError::TooFewDraws {
            what: "R-hat",
            have: draws,
            needed: MIN_DRAWS,
        });
    }
    for c in 0..chains {
        if let Some((index, value)) = (0..draws)
            .map(|t| (t, at(c, t)))
            .find(|(_, v)| !v.is_finite())
        {
            return Err(DiagnosticsError::NonFinite {
                chain: c,
                index,
                value,
            });
        }
    }
    if chains < MIN_CHAINS_RHAT {
        return Err(DiagnosticsError::TooFewChains {
            what: "R-hat",
            have: chains,
            needed: MIN_CHAINS_RHAT,
        });
    }
    // The split chains (ArviZ `_split_chains`) as rows of `half` draws: the first halves of
    // every chain, then the last halves; `split(p)` is the value at position p of their
    // concatenation.
    let half = draws / 2;
    let size = 2 * chains * half;
    let split = |p: usize| {
        let (row, t) = (p / half, p % half);
        let (second, c) = (row / chains, row % chains);
        at(c, if second == 1 { draws - half + t } else { t })
    };
    let mut z = vec![0.0; size];
    let mut idx = order_by(size, split);
    fill_scores(&idx, split, &mut z);
    let scores = |z: &[f64]| {
        rhat_raw(&Mat {
            rows: 2 * chains,
            cols: half,
            data: Cow::Borrowed(z),
        })
    };
    let bulk = scores(&z);
    let med = median_at(size, &|i| split(idx[i] as usize));
    let folded = |p: usize| (split(p) - med).abs();
    idx.sort_by(|&a, &b| folded(a as usize).total_cmp(&folded(b as usize)));
    fill_scores(&idx, folded, &mut z);
    let tail = scores(&z);
    // As rhat_rank_of_split: Python's max(), NaN if either is NaN.
    Ok(if bulk.is_nan() || tail.is_nan() {
        f64::NAN
    } else {
        bulk.max(tail)
    })
}

/// Bulk ESS: Geyer ESS of the rank-normalised split chains (ArviZ `ess(method="bulk")`).
///
/// # Errors
/// Fewer than [`MIN_DRAWS`] draws, empty, ragged or non-finite input.
pub fn ess_bulk(chains: &[&[f64]]) -> Result<f64, DiagnosticsError> {
    Ok(ess_bulk_mat(&checked(chains, "bulk ESS")?))
}

/// Tail ESS: the smaller ESS of the 5% and 95% quantile indicators (ArviZ
/// `ess(method="tail")`).
///
/// # Errors
/// As [`ess_bulk`].
pub fn ess_tail(chains: &[&[f64]]) -> Result<f64, DiagnosticsError> {
    Ok(ess_tail_mat(&checked(chains, "tail ESS")?))
}

/// ESS of the mean: Geyer ESS of the split chains, no rank transform (ArviZ
/// `ess(method="mean")`).
///
/// # Errors
/// As [`ess_bulk`].
pub fn ess_mean(chains: &[&[f64]]) -> Result<f64, DiagnosticsError> {
    Ok(ess_mean_mat(&checked(chains, "ESS of the mean")?))
}

/// Monte-Carlo standard error of the mean: `sd / sqrt(ess_mean)` (ArviZ `mcse(method="mean")`).
///
/// # Errors
/// As [`ess_bulk`].
pub fn mcse_mean(chains: &[&[f64]]) -> Result<f64, DiagnosticsError> {
    Ok(mcse_mean_mat(&checked(chains, "MCSE of the mean")?))
}

/// Monte-Carlo standard error of the standard deviation (ArviZ `mcse(method="sd")`).
///
/// # Errors
/// As [`ess_bulk`].
pub fn mcse_sd(chains: &[&[f64]]) -> Result<f64, DiagnosticsError> {
    Ok(mcse_sd_mat(&checked(chains, "MCSE of the sd")?))
}

/// Monte-Carlo standard error of the `prob` quantile (ArviZ `mcse(method="quantile")`): half
/// the distance between the order statistics at the beta quantiles of the +-1 sd band.
///
/// # Errors
/// As [`ess_bulk`], and `prob` outside (0, 1).
pub fn mcse_quantile(chains: &[&[f64]], prob: f64) -> Result<f64, DiagnosticsError> {
    check_prob("prob", prob, false)?;
    Ok(mcse_quantile_mat(
        &checked(chains, "MCSE of a quantile")?,
        prob,
    ))
}

fn checked_draws(draws: &[f64], what: &'static str) -> Result<(), DiagnosticsError> {
    validate_chains(&[draws], 1, what).map(|_| ())
}

/// numpy's default (`method="linear"`) quantile of sorted values.
pub(crate) fn quantile_sorted(s: &[f64], p: f64) -> f64 {
    quantile_at(s.len(), &|i| s[i], p)
}

/// [`quantile_sorted`] of `n` sorted values given by `at`.
pub(crate) fn quantile_at(n: usize, at: &dyn Fn(usize) -> f64, p: f64) -> f64 {
    let virt = (n - 1) as f64 * p;
    if virt >= (n - 1) as f64 {
        return at(n - 1);
    }
    if virt < 0.0 {
        return at(0);
    }
    let prev = virt.floor();
    let gamma = virt - prev;
    let (a, b) = (at(prev as usize), at(prev as usize + 1));
    let diff = b - a;
    // numpy's _lerp: interpolate from the nearer end for accuracy.
    if gamma >= 0.5 {
        b - diff * (1.0 - gamma)
    } else {
        a + diff * gamma
    }
}

/// Per point, the `probs` quantiles ([`quantile`]'s) over the rows of `values[row][point]`:
/// `out[q][point]`, each column sorted once for all of `probs`. Non-finite values are
/// skipped; a point with none left is NaN.
pub(crate) fn pointwise_quantiles(
    values: &[Vec<f64>],
    points: usize,
    probs: &[f64],
) -> Vec<Vec<f64>> {
    let mut out = vec![vec![f64::NAN; points]; probs.len()];
    let mut column = Vec::with_capacity(values.len());
    for j in 0..points {
        column.clear();
        column.extend(values.iter().map(|row| row[j]).filter(|v| v.is_finite()));
        if column.is_empty() {
            continue;
        }
        column.sort_by(f64::total_cmp);
        for (q, &p) in probs.iter().enumerate() {
            out[q][j] = quantile_sorted(&column, p);
        }
    }
    out
}

/// The `p` quantile of pooled draws, numpy's default linear interpolation (type 7).
///
/// # Errors
/// Empty or non-finite draws, `p` outside [0, 1].
pub fn quantile(draws: &[f64], p: f64) -> Result<f64, DiagnosticsError> {
    if !(0.0..=1.0).contains(&p) {
        return Err(DiagnosticsError::InvalidArgument {
            name: "p",
            value: p,
            reason: "a quantile probability must lie in [0, 1]",
        });
    }
    checked_draws(draws, "a quantile")?;
    Ok(quantile_sorted(&sorted(draws), p))
}

/// The equal-tailed interval of probability `prob`: the `(1 - prob)/2` and `(1 + prob)/2`
/// quantiles (numpy linear).
///
/// # Errors
/// Empty or non-finite draws, `prob` outside (0, 1].
pub fn equal_tailed_interval(draws: &[f64], prob: f64) -> Result<(f64, f64), DiagnosticsError> {
    check_prob("prob", prob, true)?;
    checked_draws(draws, "an equal-tailed interval")?;
    let s = sorted(draws);
    Ok(eti_sorted(&s, prob))
}

pub(crate) fn eti_sorted(s: &[f64], prob: f64) -> (f64, f64) {
    eti_at(s.len(), &|i| s[i], prob)
}

/// [`eti_sorted`] of `n` sorted values given by `at`.
pub(crate) fn eti_at(n: usize, at: &dyn Fn(usize) -> f64, prob: f64) -> (f64, f64) {
    (
        quantile_at(n, at, (1.0 - prob) / 2.0),
        quantile_at(n, at, (1.0 + prob) / 2.0),
    )
}

/// Highest-density interval of probability `prob` for a unimodal posterior (ArviZ `hdi`): the
/// narrowest interval between two order statistics `floor(prob n)` apart.
///
/// # Errors
/// Empty or non-finite draws, `prob` outside (0, 1) (ArviZ fails at `prob = 1` as well).
pub fn hdi(draws: &[f64], prob: f64) -> Result<(f64, f64), DiagnosticsError> {
    check_prob("prob", prob, false)?;
    checked_draws(draws, "an HDI")?;
    hdi_sorted(&sorted(draws), prob)
}

pub(crate) fn hdi_sorted(s: &[f64], prob: f64) -> Result<(f64, f64), DiagnosticsError> {
    let inc = hdi_span(s.len(), prob)?;
    Ok(hdi_scan(s.iter().copied(), s[inc..].iter().copied()))
}

/// The distance `floor(prob n)` between the order statistics that bound an HDI of `n` draws.
pub(crate) fn hdi_span(n: usize, prob: f64) -> Result<usize, DiagnosticsError> {
    let inc = (prob * n as f64).floor() as usize;
    if inc >= n {
        // Only reachable when prob * n rounds up to n.
        return Err(DiagnosticsError::InvalidArgument {
            name: "prob",
            value: prob,
            reason: "floor(prob * n) must be below the number of draws n for an HDI",
        });
    }
    Ok(inc)
}

/// The narrowest of the intervals `(low_i, high_i)`, where `lows` yields the sorted draws
/// `s[0..]` and `highs` the sorted draws `s[inc..]` (the scan stops with the shorter): the
/// first narrowest wins, as `np.argmin`. Two streams over the sorted draws suffice, so an
/// HDI needs no copy of them in memory.
pub(crate) fn hdi_scan(
    lows: impl IntoIterator<Item = f64>,
    highs: impl IntoIterator<Item = f64>,
) -> (f64, f64) {
    let mut best = None;
    let mut best_w = f64::INFINITY;
    for (low, high) in lows.into_iter().zip(highs) {
        // Index 0 unless a narrower interval is found, as in the loop over indices.
        best.get_or_insert((low, high));
        let w = high - low;
        // Strict: the first narrowest interval wins, as np.argmin.
        if w < best_w {
            best_w = w;
            best = Some((low, high));
        }
    }
    best.unwrap_or((f64::NAN, f64::NAN))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The padding is the smallest 5-smooth length at or above its argument, and the
    /// autocovariance through it is the direct sum's, at a length whose double has a large
    /// prime factor (2 × 191) and at others.
    #[test]
    fn autocovariances_padded_to_a_fast_length_are_the_direct_sums() {
        let smooth = |mut m: usize| {
            for p in [2, 3, 5] {
                while m % p == 0 {
                    m /= p;
                }
            }
            m == 1
        };
        for n in 1..2_000 {
            let len = next_fast_len(n);
            assert!(len >= n && smooth(len), "{n}: {len}");
            assert!(
                (n..len).all(|m| !smooth(m)),
                "{n}: {len} is not the smallest"
            );
        }
        assert_eq!(next_fast_len(382), 384);
        for n in [1, 2, 7, 191, 382] {
            let row: Vec<f64> = (0..n).map(|t| ((t * 37 % 11) as f64).sin()).collect();
            let mu = mean(&row);
            let mut got = vec![0.0; n];
            let m = Autocov::new(n).of(&row, |t, v| got[t] = v);
            assert_eq!(m.to_bits(), mu.to_bits());
            for (k, g) in got.iter().enumerate() {
                let direct: f64 = (0..n - k).map(|t| (row[t] - mu) * (row[t + k] - mu)).sum();
                let direct = direct / n as f64;
                assert!(
                    (g - direct).abs() < 1e-12,
                    "n {n}, lag {k}: {g} and {direct}"
                );
            }
        }
    }

    /// [`rhat_by`] reads the chains where they are and gives [`rhat`] to the bit: odd and
    /// even lengths, ties (a value repeated, -0.0 and 0.0), a constant set of chains, and the
    /// same errors.
    #[test]
    fn rhat_by_is_rhat_to_the_bit() {
        let value = |c: usize, t: usize, n: usize| {
            let k = (c * 7919 + t * 104_729 + n) % 23;
            if k == 0 {
                -0.0
            } else {
                (k as f64 / 4.0).round() - 2.0 + 0.1 * c as f64 * (t % 3) as f64
            }
        };
        for (chains, draws) in [(2, 4), (3, 9), (4, 40), (2, 41)] {
            let data: Vec<Vec<f64>> = (0..chains)
                .map(|c| (0..draws).map(|t| value(c, t, draws)).collect())
                .collect();
            let refs: Vec<&[f64]> = data.iter().map(Vec::as_slice).collect();
            let expected = rhat(&refs).unwrap();
            let got = rhat_by(chains, draws, &|c, t| data[c][t]).unwrap();
            assert_eq!(got.to_bits(), expected.to_bits(), "{chains} × {draws}");
        }
        let constant = rhat_by(3, 10, &|_, _| 1.5).unwrap();
        assert!(
            constant.is_nan()
                && rhat(&[&[1.5; 10], &[1.5; 10], &[1.5; 10]])
                    .unwrap()
                    .is_nan()
        );
        let bad = |c: usize, t: usize| if (c, t) == (1, 2) { f64::NAN } else { 1.0 };
        assert!(matches!(
            rhat_by(2, 5, &bad),
            Err(DiagnosticsError::NonFinite {
                chain: 1,
                index: 2,
                ..
            })
        ));
        assert!(matches!(
            rhat_by(1, 5, &|_, t| t as f64),
            Err(DiagnosticsError::TooFewChains { .. })
        ));
        assert!(matches!(
            rhat_by(2, 3, &|_, t| t as f64),
            Err(DiagnosticsError::TooFewDraws { .. })
        ));
    }
}
