//! The Rust side of the comparison with emcee (`benches/peer/compare_emcee.py`) and an
//! interleaved overhead measurement.
//!
//! ```text
//! cargo run --release --no-default-features --example sampler_peer -- run \
//!     --precision P.txt --init INIT.txt --walkers 32 --steps 20000 --ensembles 1 \
//!     --seed 1 --out chain.f64
//! cargo run --release --no-default-features --example sampler_peer -- overhead --reps 9
//! ```
//!
//! `run` samples the Gaussian with the given precision matrix (text, one row per line)
//! from the first `ensembles × walkers` rows of INIT.txt with the stretch move (a = 2),
//! keeping every draw in preallocated memory like emcee's backend (no checkpoints), writes the chains as raw
//! little-endian f64 (`ensembles × steps × walkers × ndim`) and prints one JSON line with the
//! wall time of the sampling call and the evaluation count.
//!
//! `overhead` times, alternately and `reps` times, the stretch-step floor, the density alone
//! and a serial run (with its end-of-run work timed separately), all on the 32-walker 10-D
//! standard normal of `benches/sampler.rs`, and prints per-repetition ratios and their median
//! — robust to a machine whose load changes between criterion benchmarks. It uses the
//! thread's CPU time (`--wall true` for wall time; parallel runs need wall time).

use std::hint::black_box;
use std::io::Write;
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use slipbayes::density::{LogDensity, LogDensityError};
use slipbayes::sampler::{
    ChainSink, EnsembleSampler, Move, NullSink, SamplerConfig, Silent, StepView, Steps,
};

/// Keeps the chain like emcee's in-memory backend: positions and log-densities in buffers
/// preallocated for the whole run; checkpoints are ignored (emcee's backend has none).
struct ChainBuffer {
    positions: Vec<Vec<f64>>,
    log_density: Vec<Vec<f64>>,
}

impl ChainBuffer {
    fn new(ensembles: usize, steps: u64, walkers: usize, ndim: usize) -> Self {
        let n = steps as usize * walkers;
        Self {
            positions: (0..ensembles)
                .map(|_| Vec::with_capacity(n * ndim))
                .collect(),
            log_density: (0..ensembles).map(|_| Vec::with_capacity(n)).collect(),
        }
    }

    fn write(&self, path: &str) {
        let mut f = std::io::BufWriter::new(std::fs::File::create(path).expect("create --out"));
        for v in self.positions.iter().flatten() {
            f.write_all(&v.to_le_bytes()).expect("write chain");
        }
        f.flush().expect("write chain");
    }
}

impl ChainSink for ChainBuffer {
    type Error = std::convert::Infallible;
    fn record(&mut self, step: &StepView<'_>) -> Result<(), Self::Error> {
        self.positions[step.ensemble].extend_from_slice(step.positions);
        self.log_density[step.ensemble].extend_from_slice(step.log_density);
        Ok(())
    }
    fn checkpoint<S: serde::Serialize>(&mut self, _state: &S) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// Unnormalised Gaussian log-density `−½ xᵀ P x`.
struct Gaussian {
    precision: Vec<f64>,
    n: usize,
}

impl LogDensity for Gaussian {
    fn dim(&self) -> usize {
        self.n
    }
    fn log_density(&self, x: &[f64], _d: &mut [f64]) -> Result<f64, LogDensityError> {
        let mut q = 0.0;
        for (i, row) in self.precision.chunks_exact(self.n).enumerate() {
            let r: f64 = row.iter().zip(x).map(|(p, v)| p * v).sum();
            q += x[i] * r;
        }
        Ok(-0.5 * q)
    }
}

fn read_matrix(path: &str) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {path}: {e}"));
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split_whitespace()
                .map(|v| v.parse().unwrap_or_else(|e| panic!("{path}: {v}: {e}")))
                .collect()
        })
        .collect()
}

fn arg(args: &[String], name: &str) -> Option<String> {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1).cloned())
}

fn num(args: &[String], name: &str, default: u64) -> u64 {
    arg(args, name).map_or(default, |v| {
        v.parse().unwrap_or_else(|e| panic!("{name} {v}: {e}"))
    })
}

fn run(args: &[String]) {
    let precision = read_matrix(&arg(args, "--precision").expect("--precision FILE"));
    let init = read_matrix(&arg(args, "--init").expect("--init FILE"));
    let walkers = num(args, "--walkers", 32) as usize;
    let steps = num(args, "--steps", 20_000);
    let ensembles = num(args, "--ensembles", 1) as usize;
    let seed = num(args, "--seed", 1);
    let out = arg(args, "--out");
    let n = precision.len();
    let g = Gaussian {
        precision: precision.concat(),
        n,
    };
    assert!(init.len() >= walkers * ensembles, "INIT has too few rows");
    let start: Vec<Vec<Vec<f64>>> = init
        .chunks(walkers)
        .take(ensembles)
        .map(<[Vec<f64>]>::to_vec)
        .collect();
    let config = SamplerConfig::new(walkers, ensembles, seed)
        .expect("valid config")
        .with_moves(vec![(Move::Stretch { a: 2.0 }, 1.0)])
        .expect("valid move");
    let mut sampler = EnsembleSampler::new(&g, config, start).expect("valid start");
    let mut sink = ChainBuffer::new(ensembles, steps, walkers, n);
    let t = Instant::now();
    let report = sampler
        .run(Steps::Fixed(steps), &mut sink, &mut Silent)
        .expect("run succeeds");
    let wall = t.elapsed().as_secs_f64();
    // The end-of-run work inside that wall time (final checkpoint, τ and R̂ report), timed
    // alone on the final state: `run(Fixed(0))`.
    let config = sampler.config().clone();
    let mut end = EnsembleSampler::from_state(&g, config, sampler.state()).expect("same density");
    let t = Instant::now();
    end.run(Steps::Fixed(0), &mut NullSink, &mut Silent)
        .expect("run succeeds");
    let report_s = t.elapsed().as_secs_f64();
    if let Some(path) = out {
        sink.write(&path);
    }
    println!(
        "{{\"wall_s\": {wall}, \"report_s\": {report_s}, \"steps\": {steps}, \"walkers\": {walkers}, \"ensembles\": {ensembles}, \
         \"ndim\": {n}, \"evaluations\": {}, \"acceptance\": {}, \"threads\": {}}}",
        report.evaluations() - (walkers * ensembles) as u64,
        report.mean_acceptance(),
        rayon::current_num_threads()
    );
}

#[path = "../benches/support/floor.rs"]
mod floor;
use floor::Floor;

const WALKERS: usize = 32;
const NDIM: usize = 10;
const STEPS: u64 = 20_000;

/// The 10-D standard normal of the criterion bench.
struct Cheap;

impl LogDensity for Cheap {
    fn dim(&self) -> usize {
        NDIM
    }
    fn log_density(&self, x: &[f64], _d: &mut [f64]) -> Result<f64, LogDensityError> {
        Ok(-0.5 * x.iter().map(|v| v * v).sum::<f64>())
    }
}

fn start(seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..WALKERS)
        .map(|_| (0..NDIM).map(|_| rng.random::<f64>() - 0.5).collect())
        .collect()
}

/// CPU time of the calling thread, in ns: unlike wall time it does not count the time the
/// thread waits while other processes run on a shared machine.
fn thread_cpu_ns() -> f64 {
    #[repr(C)]
    struct Timespec {
        sec: i64,
        nsec: i64,
    }
    extern "C" {
        fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
    }
    const CLOCK_THREAD_CPUTIME_ID: i32 = 3;
    let mut ts = Timespec { sec: 0, nsec: 0 };
    // SAFETY: clock_gettime writes one timespec (two C longs on 64-bit Linux) into `ts`.
    let rc = unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime failed");
    ts.sec as f64 * 1e9 + ts.nsec as f64
}

/// A clock: thread CPU time, or wall time with `--wall true`.
struct Clock(bool);

impl Clock {
    fn now(&self) -> f64 {
        if self.0 {
            thread_cpu_ns()
        } else {
            WALL.with(|t| t.elapsed().as_secs_f64() * 1e9)
        }
    }
}

thread_local! {
    static WALL: Instant = Instant::now();
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn overhead(args: &[String]) {
    let reps = num(args, "--reps", 9) as usize;
    let parallel = arg(args, "--parallel").is_some_and(|v| v == "true");
    let wall = arg(args, "--wall").is_some_and(|v| v == "true");
    assert!(
        !parallel || wall,
        "--parallel true needs --wall true (CPU time counts one thread)"
    );
    let clock = Clock(!wall);
    let per = (STEPS * WALKERS as u64) as f64;
    let mut floor = Floor::<WALKERS, NDIM>::new(start(7).concat(), 7);
    let mut points = Vec::new();
    for _ in 0..STEPS * 2 {
        floor.step();
        points.extend_from_slice(floor.proposals());
    }
    let (mut f_ns, mut d_ns, mut r_ns, mut e_ns, mut ratio) =
        (vec![], vec![], vec![], vec![], vec![]);
    let (mut m_ns, mut ratio_m) = (vec![], vec![]);
    for rep in 0..reps {
        let t = clock.now();
        for _ in 0..STEPS {
            floor.step();
        }
        let f = (clock.now() - t) / per;

        let t = clock.now();
        let mut acc = 0.0;
        for x in black_box(&points).chunks(NDIM) {
            acc += Cheap.log_density(x, &mut []).unwrap_or(0.0);
        }
        black_box(acc);
        let d = (clock.now() - t) / (points.len() / NDIM) as f64;

        let config = SamplerConfig::new(WALKERS, 1, 2024 + rep as u64)
            .expect("valid config")
            .with_parallel(parallel);
        let mut s = EnsembleSampler::new(&Cheap, config.clone(), vec![start(rep as u64)])
            .expect("valid start");
        let t = clock.now();
        s.run(Steps::Fixed(STEPS), &mut NullSink, &mut Silent)
            .expect("run succeeds");
        let r = (clock.now() - t) / per;

        // A run twice as long: the difference is the marginal cost of a step, free of
        // one-time costs (history memory first touched, end-of-run τ and R̂).
        let mut long = EnsembleSampler::new(&Cheap, config.clone(), vec![start(rep as u64)])
            .expect("valid start");
        let t = clock.now();
        long.run(Steps::Fixed(2 * STEPS), &mut NullSink, &mut Silent)
            .expect("run succeeds");
        let m = (clock.now() - t) / per - r;

        let mut again =
            EnsembleSampler::from_state(&Cheap, config, s.state()).expect("same density");
        let t = clock.now();
        again
            .run(Steps::Fixed(0), &mut NullSink, &mut Silent)
            .expect("run succeeds");
        let e = (clock.now() - t) / per;

        let q = (r - e - d) / f;
        let qm = (m - d) / f;
        eprintln!(
            "rep {rep}: floor {f:.2} ns, density {d:.2} ns, run {r:.2} ns, end {e:.2} ns, marginal {m:.2} ns per walker-step; (run − end − density)/floor = {q:.2}, (marginal − density)/floor = {qm:.2}"
        );
        m_ns.push(m);
        ratio_m.push(qm);
        f_ns.push(f);
        d_ns.push(d);
        r_ns.push(r);
        e_ns.push(e);
        ratio.push(q);
    }
    println!(
        "{{\"floor_ns\": {:.3}, \"density_ns\": {:.3}, \"run_ns\": {:.3}, \"run_end_ns\": {:.3}, \"ratio\": {:.3}, \"marginal_ns\": {:.3}, \"marginal_ratio\": {:.3}, \"reps\": {reps}, \"parallel\": {parallel}, \"clock\": \"{}\"}}",
        median(&mut f_ns),
        median(&mut d_ns),
        median(&mut r_ns),
        median(&mut e_ns),
        median(&mut ratio),
        median(&mut m_ns),
        median(&mut ratio_m),
        if wall { "wall" } else { "thread_cpu" }
    );
}

/// The 6-D one-contact friction posterior (`benches/peer/one_contact.toml`): our sampler
/// alone (emcee would need the law in Python), serial and parallel evaluation.
fn posterior(args: &[String]) {
    use slipbayes::model::{ModelSpec, Posterior};
    let model = arg(args, "--model").unwrap_or_else(|| "benches/peer/one_contact.toml".into());
    let walkers = num(args, "--walkers", 32) as usize;
    let steps = num(args, "--steps", 2000);
    let ensembles = num(args, "--ensembles", 1) as usize;
    let parallel = arg(args, "--parallel").is_none_or(|v| v == "true");
    let out = arg(args, "--out");
    let spec = ModelSpec::load(std::path::Path::new(&model)).expect("model file loads");
    let post = Posterior::new(&spec).expect("posterior builds");
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let start = slipbayes::optimize::initial_around_optimum(
        &post,
        post.start(),
        walkers,
        ensembles,
        &mut rng,
    )
    .expect("start around the optimum");
    let config = SamplerConfig::new(walkers, ensembles, 1)
        .expect("valid config")
        .with_moves(vec![(Move::Stretch { a: 2.0 }, 1.0)])
        .expect("valid move")
        .with_parallel(parallel);
    let mut sampler = EnsembleSampler::new(&post, config, start.walkers).expect("valid start");
    let mut sink = ChainBuffer::new(ensembles, steps, walkers, post.dim());
    let t = Instant::now();
    let report = sampler
        .run(Steps::Fixed(steps), &mut sink, &mut Silent)
        .expect("run succeeds");
    let wall = t.elapsed().as_secs_f64();
    if let Some(path) = out {
        sink.write(&path);
    }
    let rejected: u64 = report
        .ensembles
        .iter()
        .flat_map(|e| e.rejections.values())
        .sum();
    println!(
        "{{\"wall_s\": {wall}, \"steps\": {steps}, \"walkers\": {walkers}, \"ensembles\": {ensembles}, \
         \"ndim\": {}, \"evaluations\": {}, \"rejected\": {rejected}, \"acceptance\": {}, \"threads\": {}, \"parallel\": {parallel}}}",
        post.dim(),
        report.evaluations() - (walkers * ensembles) as u64,
        report.mean_acceptance(),
        rayon::current_num_threads()
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("run") => run(&args),
        Some("overhead") => overhead(&args),
        Some("posterior") => posterior(&args),
        _ => {
            eprintln!("usage: sampler_peer run --precision P --init I [--walkers 32] [--steps 20000] [--ensembles 1] [--seed 1] [--out FILE]\n       sampler_peer overhead [--reps 9] [--wall true] [--parallel true]");
            std::process::exit(2);
        }
    }
}
