//! Long records on sufficient statistics (docs/model.md §5, "Long records"): the reduced
//! log-density agrees with the exact one within the tolerance at draws around the posterior,
//! on the PTFE contact and on the hard cases of docs/model.md §8; the interpolation error of
//! every bin stays within its estimate; kinks open their bins; a tolerance of 0 and short
//! records are evaluated exactly, bit for bit.

use std::path::Path;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use slipbayes::data::Series;
use slipbayes::density::{BlockUpdate, BlockedDensity, LogDensity, Target};
use slipbayes::law::{Elastic, Law, LawParams, ObservedSlide, Scene};
use slipbayes::model::data::RunData;
use slipbayes::model::sufficient::{
    max_error_for, plan_bins, ChebyshevBasis, PlanSettings, Reduction, ReferenceModel,
};
use slipbayes::model::Posterior;
use slipbayes::optimize::initial_around_optimum;
use slipbayes::run_file::RunFile;
use slipbayes::simulate::{simulate, SimulationSpec};

/// A first slide (and the repeat slide after it) simulated at 1 nm/s.
#[derive(Debug, Clone, Copy)]
struct Slide {
    name: &'static str,
    alpha: f64,
    a: f64,
    f_d: f64,
    t0: f64,
    k: f64,
    sigma: f64,
    duration_s: f64,
    interval_s: f64,
    repeat: bool,
}

const PTFE: Slide = Slide {
    name: "PTFE, 10^5 points",
    alpha: 0.92e6,
    a: 6.2e-3,
    f_d: 10e-3,
    t0: 14.8,
    k: 1.2e4,
    sigma: 1e-4,
    duration_s: 20_000.0,
    interval_s: 0.2,
    repeat: true,
};

const VELOCITY: f64 = 1e-9;

impl Slide {
    fn series(&self) -> (Series, Option<Series>) {
        let params = LawParams::new(self.alpha, self.a, self.f_d, self.t0).unwrap();
        let spec = |scene, duration_s, seed, after_first_s| SimulationSpec {
            scene,
            params,
            stiffness_n_per_m: Some(self.k),
            law: Default::default(),
            rigid: false,
            velocity_m_per_s: VELOCITY,
            duration_s,
            interval_s: self.interval_s,
            noise_sd_n: self.sigma,
            seed,
            f_end_n: None,
            after_first_s,
            normal_force_n: None,
            normal_noise_sd_n: 0.0,
        };
        let first = simulate(&spec(Scene::First, self.duration_s, 1, None))
            .unwrap()
            .series;
        let repeat = self.repeat.then(|| {
            simulate(&spec(Scene::Repeat, 2_000.0, 2, Some(self.duration_s)))
                .unwrap()
                .series
        });
        (first, repeat)
    }

    /// The posterior of the slide(s) under a `[likelihood]` table.
    fn posterior(&self, likelihood: &str) -> Posterior {
        let (first, repeat) = self.series();
        posterior_of(first, repeat, likelihood)
    }
}

fn posterior_of(first: Series, repeat: Option<Series>, likelihood: &str) -> Posterior {
    let mut text = String::from(
        "[[material]]\nname = \"m\"\n[[contact]]\nname = \"c\"\nmaterial = \"m\"\n\
         [[run]]\nname = \"first\"\ncontact = \"c\"\ndata = \"first.csv\"\n\
         velocity_m_per_s = 1e-9\nscene = \"first\"\n",
    );
    if repeat.is_some() {
        text += "[[run]]\nname = \"repeat\"\ncontact = \"c\"\ndata = \"repeat.csv\"\n\
                 velocity_m_per_s = 1e-9\nscene = \"repeat\"\n";
    }
    text += likelihood;
    let spec = RunFile::parse(&text, Path::new("model.toml")).unwrap();
    let mut data = vec![RunData::for_series(&spec.model, 0, first).unwrap()];
    if let Some(r) = repeat {
        data.push(RunData::for_series(&spec.model, 1, r).unwrap());
    }
    Posterior::from_data(&spec.model, spec.blocking(), data).unwrap()
}

/// Index of the first name starting with `prefix`.
fn position_of(names: &[String], prefix: &str) -> usize {
    names
        .iter()
        .position(|n| n.starts_with(prefix))
        .unwrap_or_else(|| panic!("no name starting with {prefix} in {names:?}"))
}

fn lp(p: &Posterior, x: &[f64]) -> f64 {
    p.log_density(x, &mut []).unwrap()
}

/// Points around the posterior: draws from the Laplace approximation at the reduced
/// posterior's mode (another seed than the reference points'), and the same draws pushed
/// three times as far from their mean.
fn draws_around(p: &Posterior) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let start =
        initial_around_optimum(Target::blocked(p), p.search_start(), 24, 1, &mut rng).unwrap();
    let draws = start.walkers.into_iter().next().unwrap();
    let dim = draws[0].len();
    let mean: Vec<f64> = (0..dim)
        .map(|c| draws.iter().map(|w| w[c]).sum::<f64>() / draws.len() as f64)
        .collect();
    let far: Vec<Vec<f64>> = draws
        .iter()
        .map(|w| mean.iter().zip(w).map(|(m, v)| m + 3.0 * (v - m)).collect())
        .collect();
    draws.into_iter().chain(far).collect()
}

/// Largest |ℓ_reduced − ℓ_exact| over `points` where both are finite, and how many were.
fn largest_difference(reduced: &Posterior, exact: &Posterior, points: &[Vec<f64>]) -> (f64, usize) {
    let mut worst: f64 = 0.0;
    let mut compared = 0;
    for x in points {
        let (Ok(r), Ok(e)) = (
            reduced.log_density(x, &mut []),
            exact.log_density(x, &mut []),
        ) else {
            continue;
        };
        worst = worst.max((r - e).abs());
        compared += 1;
    }
    (worst, compared)
}

/// Each long run is reduced with a stated bound within its share of the model's tolerance,
/// and the log-density agrees with the exact one within that tolerance at draws around the
/// posterior: the PTFE contact and the hard cases of docs/model.md §8 (t0 = 1e-6 s, k near the
/// stick-slip limit, noise half of F_d, tiny noise against large forces, a/F_d = 20, a → 0).
#[test]
fn reduced_log_density_is_within_the_tolerance_of_the_exact_one() {
    let cases = [
        PTFE,
        Slide {
            name: "t0 = 1e-6 s",
            t0: 1e-6,
            // The peak is higher (F_peak falls with ln t0): a stiffer machine keeps it stable.
            k: 1e5,
            repeat: false,
            ..PTFE
        },
        Slide {
            name: "k near the stick-slip limit",
            k: 3.4e3,
            repeat: false,
            ..PTFE
        },
        Slide {
            name: "noise half of F_d",
            sigma: 5e-3,
            repeat: false,
            ..PTFE
        },
        Slide {
            name: "noise 1e-7 N against forces of 2e-2 N",
            sigma: 1e-7,
            repeat: false,
            ..PTFE
        },
        Slide {
            name: "a/F_d = 20",
            a: 0.2,
            k: 1e6,
            repeat: false,
            ..PTFE
        },
        Slide {
            name: "a -> 0",
            a: 1e-7,
            repeat: false,
            ..PTFE
        },
    ];
    for case in cases {
        let reduced = case.posterior("");
        let exact = case.posterior("[likelihood]\ntolerance = 0\n");
        let provenance = reduced.data_provenance();
        let mut tolerance = 0.0;
        for d in &provenance {
            let b = d
                .binning
                .unwrap_or_else(|| panic!("{}: run {} not reduced", case.name, d.run));
            // The bound holds where the residuals' RMS is at least the noise it is stated at:
            // that must not exceed the noise of the data.
            assert!(
                b.noise_n <= 0.55 * case.sigma,
                "{}: bound stated at {} for noise {}",
                case.name,
                b.noise_n,
                case.sigma
            );
            assert!(b.bound <= b.tolerance, "{}: {b:?}", case.name);
            assert_eq!(d.points_used, d.points_read);
            assert!(b.evaluations * 10 < d.points_used, "{}: {b:?}", case.name);
            tolerance += b.tolerance;
        }
        // The model's tolerance, shared by its long runs.
        assert!(
            (tolerance - 0.01).abs() < 1e-15,
            "{}: {tolerance}",
            case.name
        );
        assert!(exact.data_provenance().iter().all(|d| d.binning.is_none()));
        let points = draws_around(&reduced);
        let (worst, compared) = largest_difference(&reduced, &exact, &points);
        eprintln!(
            "{}: |Δ log-density| ≤ {worst:.2e} at {compared} points; {:?}",
            case.name,
            provenance.iter().map(|d| d.binning).collect::<Vec<_>>()
        );
        assert!(compared >= 24, "{}: {compared} points compared", case.name);
        assert!(
            worst <= tolerance,
            "{}: {worst} above {tolerance}",
            case.name
        );
    }
}

/// A walker that puts t0 (and the end of the elastic loading) inside a bin opens that bin:
/// the log-density stays within the tolerance of the exact one. Without opening it the
/// polynomial would follow the kink, off by far more.
#[test]
fn a_kink_inside_a_bin_opens_it() {
    let reduced = PTFE.posterior("");
    let exact = PTFE.posterior("[likelihood]\ntolerance = 0\n");
    let t0 = position_of(&reduced.param_names(), "ln_t0");
    let mut compared = 0;
    for factor in [0.5, 0.8, 1.25, 2.0, 4.0] {
        let mut x = reduced.start().to_vec();
        x[t0] += f64::ln(factor);
        let (Ok(r), Ok(e)) = (
            reduced.log_density(&x, &mut []),
            exact.log_density(&x, &mut []),
        ) else {
            continue;
        };
        assert!((r - e).abs() <= 0.02, "t0 × {factor}: {r} against {e}");
        compared += 1;
    }
    assert!(compared >= 4);
}

/// A tolerance of 0, and a record of at most `exact_up_to` points, are evaluated point by
/// point: the same bits as the exact likelihood. The same record reduced (exact_up_to below
/// its length) differs, within the tolerance.
#[test]
fn a_tolerance_of_zero_and_short_records_are_exact() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/ptfe-c1-first.csv");
    let model = |likelihood: &str| {
        let text = format!(
            "[[material]]\nname = \"m\"\n[[contact]]\nname = \"c\"\nmaterial = \"m\"\n\
             [[run]]\nname = \"r\"\ncontact = \"c\"\ndata = \"{}\"\nvelocity_m_per_s = 1e-9\n\
             scene = \"first\"\n{likelihood}",
            data.display()
        );
        RunFile::parse(&text, Path::new("model.toml"))
            .unwrap()
            .posterior()
            .unwrap()
    };
    let default = model("");
    let zero = model("[likelihood]\ntolerance = 0\nexact_up_to = 100\n");
    let per_run = model("likelihood_tolerance = 0\n[likelihood]\nexact_up_to = 100\n");
    let reduced = model("[likelihood]\nexact_up_to = 100\n");
    assert!(default.data_provenance()[0].binning.is_none());
    assert!(zero.data_provenance()[0].binning.is_none());
    assert!(per_run.data_provenance()[0].binning.is_none());
    assert!(reduced.data_provenance()[0].binning.is_some());
    let mut differs = false;
    for x in draws_around(&default) {
        let Ok(d) = default.log_density(&x, &mut []) else {
            continue;
        };
        assert_eq!(d.to_bits(), lp(&zero, &x).to_bits());
        assert_eq!(d.to_bits(), lp(&per_run, &x).to_bits());
        let r = lp(&reduced, &x);
        assert!((r - d).abs() <= 0.01, "{r} against {d}");
        differs |= r.to_bits() != d.to_bits();
    }
    assert!(
        differs,
        "the reduced likelihood never differed: was it reduced?"
    );
}

/// The σ reported for a reduced record (drawn from its conditional posterior given the sum of
/// squared residuals of every point) is the noise of one point.
#[test]
fn the_sigma_of_a_reduced_record_is_the_noise_of_one_point() {
    let reduced = PTFE.posterior("");
    let column = position_of(&reduced.derived_names(), "sigma[first]");
    let mut derived = vec![0.0; reduced.derived_names().len()];
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let start = initial_around_optimum(
        Target::blocked(&reduced),
        reduced.search_start(),
        16,
        1,
        &mut rng,
    )
    .unwrap();
    reduced.log_density(&start.optimum.x, &mut derived).unwrap();
    // One draw from 10⁵ points: relative sd 1/√(2·10⁵) ≈ 0.2 %.
    let sigma = derived[column];
    assert!((sigma / PTFE.sigma - 1.0).abs() < 0.01, "σ = {sigma}");
}

/// The remainder of every bin, measured at each of its points against the exact model, stays
/// within the estimate the bins were chosen with, at the reference parameters; at parameters
/// between the references (a tenth of the way along each segment between them) within the
/// largest error the plan allows.
#[test]
fn every_bins_remainder_is_within_its_estimate() {
    let (first, _) = PTFE.series();
    let (times, forces) = (&first.time_s, &first.force_n);
    let slide_at = |scale: [f64; 4]| {
        let law = Law::from_rate(
            PTFE.alpha * scale[0] * VELOCITY,
            PTFE.a * scale[1],
            PTFE.f_d * scale[2],
            PTFE.t0 * scale[3],
        )
        .unwrap();
        ObservedSlide::new(law, Elastic::spring(PTFE.k, VELOCITY).unwrap())
    };
    let references = [
        slide_at([1.0, 1.0, 1.0, 1.0]),
        slide_at([1.02, 0.98, 1.01, 1.05]),
        slide_at([0.98, 1.02, 0.99, 0.95]),
    ];
    let models: Vec<Box<ReferenceModel>> = references
        .iter()
        .map(|s| {
            Box::new(move |t: &[f64], out: &mut [f64]| s.forces(t, out, None).is_ok())
                as Box<ReferenceModel>
        })
        .collect();
    let refs: Vec<&ReferenceModel> = models.iter().map(|m| m.as_ref()).collect();
    let excluded: Vec<(f64, f64)> = references
        .iter()
        .flat_map(|s| {
            let t0 = s.law().t0();
            let kv = PTFE.k * VELOCITY;
            [
                (t0, t0),
                (t0 + s.law().force(t0) / kv, t0 + s.law().force(t0) / kv),
            ]
        })
        .collect();
    let degree = 7;
    let max_error_n = max_error_for(0.01, times.len(), 0.5 * PTFE.sigma, 1.0);
    let settings = PlanSettings {
        degree,
        max_error_n,
        min_points: 32,
        max_points: 4_096,
    };
    let planned = plan_bins(times, &excluded, &settings, &refs);
    assert!(planned.len() > 10);
    let reduction = Reduction::new(times, forces, &[], degree, &planned);
    let basis = ChebyshevBasis::new(degree);
    let mut l = vec![0.0; degree + 1];
    let mut remainder = |slide: &ObservedSlide, first: usize, end: usize| {
        let (lo, hi) = (times[first], times[end - 1]);
        let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let nodes: Vec<f64> = basis.points().iter().map(|u| mid + half * u).collect();
        let mut at_nodes = vec![0.0; nodes.len()];
        slide.forces(&nodes, &mut at_nodes, None).unwrap();
        let mut exact = vec![0.0; end - first];
        slide.forces(&times[first..end], &mut exact, None).unwrap();
        let mut worst: f64 = 0.0;
        for (i, m) in (first..end).zip(exact) {
            basis.eval(((times[i] - mid) / half).clamp(-1.0, 1.0), &mut l);
            let p: f64 = l.iter().zip(&at_nodes).map(|(a, b)| a * b).sum();
            worst = worst.max((p - m).abs());
        }
        worst
    };
    let between = [
        slide_at([1.002, 0.998, 1.001, 1.005]),
        slide_at([0.998, 1.002, 0.999, 0.995]),
    ];
    for (b, (first, end, _, _)) in planned.iter().zip(reduction.bin_spans()) {
        assert_eq!((b.first, b.end), (first, end));
        for s in &references {
            let r = remainder(s, first, end);
            assert!(
                r <= b.error_n,
                "bin {first}..{end}: {r:e} above {:e}",
                b.error_n
            );
        }
        for s in &between {
            let r = remainder(s, first, end);
            assert!(
                r <= max_error_n,
                "bin {first}..{end}: {r:e} above {max_error_n:e}"
            );
        }
    }
}

/// Where each rank of an MPI job holds only its own contacts' data (`Posterior::share_of`),
/// its long runs get the bins that the whole posterior chose, bit for bit, at the points rank 0
/// hands it (they come from the whole posterior's start, which a share cannot compute), and
/// its contacts' updates give the whole posterior's bits. Three contacts, each a first slide
/// of 2 × 10⁴ points and a repeat slide of 10⁴, reduced above 5,000 points, cut 2 and 3 ways.
#[test]
fn a_share_of_the_data_reduces_its_long_runs_as_the_whole_posterior_does() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("[[material]]\nname = \"m\"\n");
    for c in 0..3 {
        let slide = Slide {
            f_d: PTFE.f_d * (1.0 + 0.1 * c as f64),
            t0: PTFE.t0 * (1.0 + 0.3 * c as f64),
            duration_s: 4_000.0,
            ..PTFE
        };
        let (first, repeat) = slide.series();
        first
            .write_csv(&dir.path().join(format!("c{c}-first.csv")))
            .unwrap();
        repeat
            .unwrap()
            .write_csv(&dir.path().join(format!("c{c}-repeat.csv")))
            .unwrap();
        text += &format!("[[contact]]\nname = \"c{c}\"\nmaterial = \"m\"\n");
        for scene in ["first", "repeat"] {
            text += &format!(
                "[[run]]\nname = \"c{c}-{scene}\"\ncontact = \"c{c}\"\ndata = \"c{c}-{scene}.csv\"\n\
                 velocity_m_per_s = 1e-9\nscene = \"{scene}\"\n"
            );
        }
    }
    text += "[likelihood]\nexact_up_to = 5000\n[sampler]\nblocks = \"contact\"\n";
    let path = dir.path().join("model.toml");
    std::fs::write(&path, text).unwrap();
    let spec = RunFile::load(&path).unwrap();
    let whole = spec.posterior().unwrap();
    let provenance = whole.data_provenance();
    let binned = |p: &[slipbayes::data::Provenance]| -> Vec<bool> {
        p.iter().map(|d| d.binning.is_some()).collect()
    };
    // Every slide is long (10⁴ points and more).
    assert_eq!(binned(&provenance), [true; 6]);
    let data_share = whole
        .data_share()
        .expect("by contact, each rank holds its contacts");

    let plan = whole.block_plan();
    let independent: Vec<usize> = (0..plan.blocks.len())
        .filter(|&b| matches!(plan.blocks[b].update, BlockUpdate::Independent { .. }))
        .collect();
    let blocks = plan.coords();
    let x = whole.start().to_vec();
    let (nd, nc) = (whole.derived_names().len(), whole.state_len());
    let (mut derived, mut cache) = (vec![0.0; nd], vec![0.0; nc]);
    whole
        .log_density_with_state(&x, &mut derived, &mut cache)
        .unwrap();
    for shares in [2, 3] {
        let mut held_by_some = vec![false; provenance.len()];
        for r in 0..shares {
            let own = |parts: usize| parts * r / shares..parts * (r + 1) / shares;
            let share =
                Posterior::share_of(&spec.model, spec.blocking(), &data_share, own).unwrap();
            let held: Vec<bool> = share
                .data_provenance()
                .iter()
                .map(|d| d.points_read > 0)
                .collect();
            for (i, d) in share.data_provenance().iter().enumerate() {
                if held[i] {
                    assert_eq!(
                        d.binning, provenance[i].binning,
                        "run {i}, share {r}/{shares}"
                    );
                    held_by_some[i] = true;
                }
            }
            for (k, &b) in independent.iter().enumerate() {
                if !own(independent.len()).contains(&k) {
                    continue;
                }
                let mut y = x.clone();
                for &i in &blocks[b] {
                    y[i] += 1e-3;
                }
                let (mut d_whole, mut c_whole) = (derived.clone(), cache.clone());
                let lp_whole = whole.log_density_after_block(b, &y, &mut d_whole, &mut c_whole);
                let (mut d, mut c) = (derived.clone(), cache.clone());
                let lp = share.log_density_after_block(b, &y, &mut d, &mut c);
                assert_eq!(
                    lp.map(f64::to_bits),
                    lp_whole.map(f64::to_bits),
                    "block {b}, share {r}/{shares}"
                );
                let bits = |v: &[f64]| v.iter().map(|u| u.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&c), bits(&c_whole), "block {b}, share {r}/{shares}");
            }
        }
        assert!(held_by_some.iter().all(|&h| h), "{shares} shares");
    }
}
