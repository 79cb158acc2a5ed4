//! `curves.json` and `truth.json`: what a report draws that the chains and `predictive.csv`
//! do not hold, written by the fit so that a report needs nothing but the run directory.
//!
//! - `curves.json`: per run, the law redrawn in interface time (first and fast slides) and
//!   the peak against t0, from the posterior draws behind `predictive.csv`.
//! - `truth.json`: the simulation behind each run whose data are synthetic (the JSON that
//!   `slipbayes simulate` writes beside a data file), for the report to overlay.
//!
//! Numbers are written in their shortest exact form; NaN and infinities, which JSON lacks,
//! as the strings `"NaN"`, `"inf"` and `"-inf"`.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::simulate::SimulationSpec;

/// What the fit redrew for the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Curves {
    /// Posterior draws behind every curve.
    pub draws: usize,
    /// Factor t0 is varied by below and above its 95 % interval in the peak against t0.
    pub t0_span: f64,
    /// Per run of the model, in its order.
    pub runs: Vec<RunCurves>,
}

/// The curves of one run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunCurves {
    /// The run.
    pub run: String,
    /// The law in interface time; `None` for a repeat slide.
    pub interface: Option<InterfaceCurve>,
    /// The peak against t0; `None` for a repeat slide and where t0 is not the run's own.
    pub peak_vs_t0: Option<PeakVsT0>,
}

/// A first or fast slide redrawn in interface time τ.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InterfaceCurve {
    /// Grid of interface times (s).
    #[serde(with = "numbers")]
    pub tau_s: Vec<f64>,
    /// F(τ) at the 2.5 %, 50 % and 97.5 % quantiles over the draws (N).
    #[serde(with = "bands")]
    pub force_n: [Vec<f64>; 3],
    /// Posterior median of k·v (N/s); `None` for a stiff slide (τ = t).
    pub kv_n_per_s: Option<f64>,
}

impl InterfaceCurve {
    /// Interface time of an observation (t, F): τ = t − F/(kv), the paper's Eq. 1 with the
    /// posterior median k.
    pub fn interface_time(&self, time_s: f64, force_n: f64) -> f64 {
        match self.kv_n_per_s {
            Some(kv) => time_s - force_n / kv,
            None => time_s,
        }
    }
}

/// The peak against t0 for one run, other parameters from the posterior (the paper's Fig. 4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PeakVsT0 {
    /// Grid of t0 (s), log-spaced.
    #[serde(with = "numbers")]
    pub t0_s: Vec<f64>,
    /// F_peak at the 2.5 %, 50 % and 97.5 % quantiles over the draws at each t0 (N).
    #[serde(with = "bands")]
    pub peak_n: [Vec<f64>; 3],
    /// The posterior draws themselves: (t0, F_peak).
    #[serde(with = "pairs")]
    pub draws: Vec<(f64, f64)>,
}

/// The simulation behind a run of synthetic data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunTruth {
    /// The run.
    pub run: String,
    /// The name of the truth file it was read from, beside the run's data file.
    pub file: String,
    /// What simulated the run's data.
    pub simulation: SimulationSpec,
}

/// A number JSON can hold: itself when finite, else its name.
#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum Number {
    Finite(f64),
    Named(String),
}

impl Number {
    fn of(x: f64) -> Self {
        if x.is_finite() {
            Self::Finite(x)
        } else if x.is_nan() {
            Self::Named("NaN".into())
        } else if x > 0.0 {
            Self::Named("inf".into())
        } else {
            Self::Named("-inf".into())
        }
    }

    fn value<E: serde::de::Error>(self) -> Result<f64, E> {
        match self {
            Self::Finite(x) => Ok(x),
            Self::Named(name) => match name.as_str() {
                "NaN" => Ok(f64::NAN),
                "inf" => Ok(f64::INFINITY),
                "-inf" => Ok(f64::NEG_INFINITY),
                other => Err(E::custom(format!(
                    "`{other}` is not a number (NaN, inf and -inf are written as strings)"
                ))),
            },
        }
    }
}

mod numbers {
    use super::*;

    pub(crate) fn serialize<S: Serializer>(values: &[f64], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(values.iter().map(|&x| Number::of(x)))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        Vec::<Number>::deserialize(d)?
            .into_iter()
            .map(Number::value)
            .collect()
    }
}

mod bands {
    use super::*;

    pub(crate) fn serialize<S: Serializer>(bands: &[Vec<f64>; 3], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(
            bands
                .iter()
                .map(|b| b.iter().map(|&x| Number::of(x)).collect::<Vec<_>>()),
        )
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[Vec<f64>; 3], D::Error> {
        let [low, median, high] = <[Vec<Number>; 3]>::deserialize(d)?;
        let values = |b: Vec<Number>| -> Result<Vec<f64>, D::Error> {
            b.into_iter().map(Number::value).collect()
        };
        Ok([values(low)?, values(median)?, values(high)?])
    }
}

mod pairs {
    use super::*;

    pub(crate) fn serialize<S: Serializer>(pairs: &[(f64, f64)], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(pairs.iter().map(|&(a, b)| [Number::of(a), Number::of(b)]))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<(f64, f64)>, D::Error> {
        Vec::<[Number; 2]>::deserialize(d)?
            .into_iter()
            .map(|[a, b]| Ok((a.value()?, b.value()?)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_read_back_exactly_with_their_nan_and_infinities() {
        let curves = Curves {
            draws: 2,
            t0_span: 30.0,
            runs: vec![RunCurves {
                run: "first".into(),
                interface: Some(InterfaceCurve {
                    tau_s: vec![0.0, 0.1 + 0.2, 5e-324],
                    force_n: [
                        vec![f64::NAN, 1.0, 2.0],
                        vec![f64::INFINITY, 1.5, 2.5],
                        vec![f64::NEG_INFINITY, -0.0, 3.0],
                    ],
                    kv_n_per_s: Some(1e-5),
                }),
                peak_vs_t0: Some(PeakVsT0 {
                    t0_s: vec![1e-3, 1.0],
                    peak_n: [vec![1.0, 2.0], vec![1.5, 2.5], vec![2.0, f64::NAN]],
                    draws: vec![(0.5, f64::NAN), (0.25, 1.75)],
                }),
            }],
        };
        let json = serde_json::to_string(&curves).unwrap();
        let back: Curves = serde_json::from_str(&json).unwrap();
        let bits = |c: &Curves| format!("{:?}", serde_json::to_value(c).unwrap());
        assert_eq!(bits(&back), bits(&curves));
        let i = back.runs[0].interface.as_ref().unwrap();
        assert!(i.force_n[0][0].is_nan() && i.force_n[2][0].is_infinite() && i.force_n[2][0] < 0.0);
        assert_eq!(i.tau_s[1].to_bits(), (0.1_f64 + 0.2).to_bits());
        assert_eq!(i.force_n[2][1].to_bits(), (-0.0_f64).to_bits());
        let bad = json.replace("\"NaN\"", "\"nan?\"");
        assert!(serde_json::from_str::<Curves>(&bad).is_err());
    }
}
