//! The law bench's slide (`benches/law.rs`: a slow PTFE first slide, 5,000 points) evaluated
//! `REPS` times by one of its rows, for counting instructions or cycles per point independently
//! of the machine's load, e.g.
//!
//! ```text
//! cargo build --release --example kernel_cost
//! valgrind --tool=callgrind --toggle-collect='kernel_cost::measured' \
//!     target/release/examples/kernel_cost lanes avx2 200
//! ```
//!
//! then the collected instruction count divided by REPS × 5,000 is the row's instructions per
//! point. Rows: `exp` (one f64::exp per point, the floor), `lanes` (the observed-time model in
//! lanes, summing the forces) and `law` (the law alone in lanes), each on `baseline`, `avx2`
//! or `avx512` (valgrind runs no AVX-512). Also `kernel_cost time [REPS]`, the smallest wall
//! time per point of each row over REPS interleaved runs and its ratio to the exp floor's (a
//! quick comparison of two builds; the bench is the measurement), and `kernel_cost counts`,
//! the kernel's paths on the slide (`KernelCounts`).

use std::hint::black_box;

use slipbayes::law::{Elastic, Law, LawParams, ObservedSlide, Simd};

/// Points per slide, as in the bench.
const POINTS: usize = 5000;

/// The bench's slide: its times, x = αvt at each, and the law through the spring and stiff.
struct Slide {
    times: Vec<f64>,
    xs: Vec<f64>,
    spring: ObservedSlide,
    stiff: ObservedSlide,
}

impl Slide {
    fn new() -> Self {
        let params = LawParams::new(0.92e6, 6.2e-3, 10e-3, 14.8).expect("valid parameters");
        let law = Law::new(&params, 1e-9).expect("valid law");
        let times: Vec<f64> = (1..=POINTS).map(|i| i as f64 * 5.0).collect();
        let xs = times.iter().map(|t| law.alpha_v() * t).collect();
        let spring = Elastic::spring(1.2e4, 1e-9).expect("valid spring");
        Self {
            times,
            xs,
            spring: ObservedSlide::new(law.clone(), spring),
            stiff: ObservedSlide::new(law, Elastic::Stiff),
        }
    }
}

/// The row's work, kept out of line so that callgrind's `--toggle-collect` counts it alone.
#[inline(never)]
fn measured(slide: &Slide, row: &str, simd: Simd, reps: usize) -> f64 {
    let mut total = 0.0;
    for _ in 0..reps {
        total += match row {
            "exp" => black_box(&slide.xs)
                .iter()
                .map(|&x| (-x).exp())
                .sum::<f64>(),
            "lanes" | "law" => {
                let observed = if row == "lanes" {
                    &slide.spring
                } else {
                    &slide.stiff
                };
                let mut sum = 0.0;
                observed
                    .for_each_force_with(simd, black_box(&slide.times), |_, _, f| sum += f)
                    .expect("stable slide");
                sum
            }
            other => panic!("unknown row {other}: exp, lanes or law"),
        };
    }
    total
}

fn main() {
    let mut args = std::env::args().skip(1);
    let row = args.next().unwrap_or_else(|| "lanes".into());
    if row == "counts" {
        let slide = Slide::new();
        println!("{:?}", slide.spring.kernel_counts(Simd::Avx2, &slide.times));
        return;
    }
    if row == "time" {
        let reps = args
            .next()
            .map_or(2000, |r| r.parse().expect("REPS is a count"));
        time_rows(reps);
        return;
    }
    let simd = match args.next().as_deref().unwrap_or("avx2") {
        "baseline" => Simd::Baseline,
        "avx2" => Simd::Avx2,
        "avx512" => Simd::Avx512,
        other => panic!("unknown instruction set {other}: baseline, avx2 or avx512"),
    };
    assert!(
        simd.is_available(),
        "{} is not available here",
        simd.as_str()
    );
    let reps = args
        .next()
        .map_or(200, |r| r.parse().expect("REPS is a count"));
    println!("{}", measured(&Slide::new(), &row, simd, reps));
}

/// Smallest wall time per point of each row over `reps` interleaved runs of one slide, and its
/// ratio to the exp floor's: a quick in-run comparison (the bench is the measurement).
fn time_rows(reps: usize) {
    let rows: Vec<(&str, Simd)> = [
        ("exp", Simd::Baseline),
        ("lanes", Simd::Avx2),
        ("lanes", Simd::Avx512),
        ("law", Simd::Avx2),
        ("law", Simd::Avx512),
    ]
    .into_iter()
    .filter(|(_, s)| s.is_available())
    .collect();
    let slide = Slide::new();
    let mut best = vec![f64::INFINITY; rows.len()];
    for _ in 0..reps {
        for (i, &(row, simd)) in rows.iter().enumerate() {
            let start = std::time::Instant::now();
            black_box(measured(&slide, row, simd, 1));
            best[i] = best[i].min(start.elapsed().as_secs_f64() * 1e9 / POINTS as f64);
        }
    }
    for (&(row, simd), &ns) in rows.iter().zip(&best) {
        println!(
            "{row:>5} {:>8} {ns:7.3} ns/pt {:5.3}x",
            simd.as_str(),
            ns / best[0]
        );
    }
}
