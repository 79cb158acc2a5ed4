//! The law evaluated in lanes: F, dF/dτ and 1/x for a batch, in the vector forms where the
//! batch allows them (see the [parent](super)'s "The law in lanes").

use super::{Lanes, Tally, LANES};
use crate::law::Law;
use crate::special::lanes::{
    d_series, d_series_close, d_subtracted, exp_neg, one_minus_exp_neg, Pieces, X_LANES_MAX,
};
use crate::special::{in_series_apart, in_series_close, in_subtraction};

/// The law's constants for batches.
pub(super) struct LawLanes<'l> {
    pub(super) law: &'l Law,
    /// Ei(x0), for D = e^(−x)[Ei(x) − Ei(x0)].
    ei0: f64,
}

impl<'l> LawLanes<'l> {
    pub(super) fn new(law: &'l Law) -> Self {
        Self {
            law,
            ei0: crate::special::ei(law.diff.x0()),
        }
    }

    /// F, dF/dτ and 1/x (x = αvτ) at every lane of `tau`.
    #[inline(always)]
    pub(super) fn force_and_rate(
        &self,
        tau: &Lanes,
        force: &mut Lanes,
        rate: &mut Lanes,
        inv_x: &mut Lanes,
        tally: &mut impl Tally,
    ) {
        let law = self.law;
        let (alpha_v, x0) = (law.alpha_v, law.diff.x0());
        let mut x = [0.0; LANES];
        for l in 0..LANES {
            x[l] = alpha_v * tau[l];
        }
        // Which forms of D the batch needs, decided from its smallest and largest x where
        // the batch lies in one regime (the bulk of a slide): subtraction holds from some x on
        // for a fixed x0 (h ≥ 2 always subtracts, 1 ≤ h < 2 does once h > x0, h < 1 never
        // does), so at the smallest x; either series holds on an interval of x, so at both
        // ends. A batch across a boundary is classified lane by lane and evaluated in each
        // form it needs; a lane in no vector form (the quadrature regime, τ before t0, x past
        // the lanes' range, NaN) sends the batch to the scalar law. The reductions are
        // pairwise, so that they cost a few vector operations rather than a chain of 16.
        let lo = reduce(&x, |a, b| if b < a { b } else { a });
        let hi = reduce(&x, |a, b| if b > a { b } else { a });
        // Every lane in [0, X_LANES_MAX], and none NaN: the smallest and largest are exact
        // where no lane is NaN, and a NaN lane makes the sum NaN (a sum of lanes in range
        // stays finite). A few vector operations, where a per-lane test gathered into one
        // flag cost a comparison and a pack per lane.
        let in_range = (lo >= 0.0) & (hi <= X_LANES_MAX) & !reduce(&x, |a, b| a + b).is_nan();
        let finite = in_range && self.ei0.is_finite();
        let mut forms = [[false; LANES]; 3];
        let (subtract, apart, close) = if !finite {
            (false, false, false)
        } else if in_subtraction(lo, x0) {
            (true, false, false)
        } else if in_series_apart(lo, x0) && in_series_apart(hi, x0) {
            (false, true, false)
        } else if in_series_close(lo, x0) && in_series_close(hi, x0) {
            (false, false, true)
        } else {
            let mut every = true;
            for l in 0..LANES {
                forms[0][l] = in_subtraction(x[l], x0);
                forms[1][l] = in_series_apart(x[l], x0);
                forms[2][l] = in_series_close(x[l], x0);
                every &= forms[0][l] | forms[1][l] | forms[2][l];
            }
            let any = |f: &[bool; LANES]| every && f.iter().any(|&b| b);
            (any(&forms[0]), any(&forms[1]), any(&forms[2]))
        };
        let forms_needed = u8::from(subtract) + u8::from(apart) + u8::from(close);
        if forms_needed == 0 {
            tally.count(|c| c.scalar_law_batches += 1);
            for l in 0..LANES {
                (force[l], rate[l]) = law.force_and_rate(tau[l]);
                inv_x[l] = 1.0 / x[l];
            }
            return;
        }
        let mut e = [0.0; LANES];
        for l in 0..LANES {
            e[l] = exp_neg(x[l]);
        }
        let mut d = [0.0; LANES];
        if forms_needed == 1 && subtract {
            d_subtracted(&x, &e, self.ei0, Pieces::spanning(lo, hi), &mut d, inv_x);
            // x ≥ 1 where D subtracts, so 1 − e^(−x) keeps its digits.
            self.assemble(&e, &d, inv_x, |l| 1.0 - e[l], force, rate);
            return;
        }
        // Near x0 (the first batches of a slide): each form into `part`, then its lanes
        // into `d`; 1/x by its own division.
        let mut part = [0.0; LANES];
        let take = |form: &[bool; LANES], part: &Lanes, d: &mut Lanes| {
            for l in 0..LANES {
                d[l] = if form[l] { part[l] } else { d[l] };
            }
        };
        if forms_needed == 1 {
            if apart {
                d_series(&x, &e, x0, hi, &mut d);
            } else {
                d_series_close(&x, &e, x0, hi, &mut d);
            }
        } else {
            if subtract {
                d_subtracted(&x, &e, self.ei0, Pieces::spanning(lo, hi), &mut part, inv_x);
                take(&forms[0], &part, &mut d);
            }
            if apart {
                d_series(&x, &e, x0, hi, &mut part);
                take(&forms[1], &part, &mut d);
            }
            if close {
                d_series_close(&x, &e, x0, hi, &mut part);
                take(&forms[2], &part, &mut d);
            }
        }
        for l in 0..LANES {
            inv_x[l] = 1.0 / x[l];
        }
        // x may be below 1/2 here, where 1 − e^(−x) is taken by its series, as the scalar law
        // takes −expm1(−x).
        self.assemble(
            &e,
            &d,
            inv_x,
            |l| one_minus_exp_neg(x[l], e[l]),
            force,
            rate,
        );
    }

    /// F and dF/dτ from e^(−x), D, 1/x and 1 − e^(−x), as in `Law::force_and_rate` (with
    /// a/τ = αv · a/x).
    #[inline(always)]
    fn assemble(
        &self,
        e: &Lanes,
        d: &Lanes,
        inv_x: &Lanes,
        one_minus_e: impl Fn(usize) -> f64,
        force: &mut Lanes,
        rate: &mut Lanes,
    ) {
        let law = self.law;
        for l in 0..LANES {
            let aging = law.a * d[l];
            force[l] = aging + law.f_d * one_minus_e(l);
            rate[l] = law.alpha_v * (law.a * inv_x[l] - (aging - law.f_d * e[l]));
        }
    }
}

/// `op` over the lanes, pairwise (`op` is min or max, as a comparison and select so that it
/// vectorises, which only NaN would tell from `f64::min`: a batch with NaN goes to the scalar
/// law whatever its smallest and largest x).
#[inline(always)]
pub(super) fn reduce(v: &Lanes, op: impl Fn(f64, f64) -> f64) -> f64 {
    let mut w = *v;
    let mut half = LANES / 2;
    while half > 0 {
        for l in 0..half {
            w[l] = op(w[l], w[l + half]);
        }
        half /= 2;
    }
    w[0]
}
