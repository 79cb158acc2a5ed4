//! Time the sampler's thread spends handing draws to the chain store: a [`ParquetSink`] fed
//! as a fit feeds it (every step of every ensemble recorded, a checkpoint every 200 steps, then
//! `finish`), with random values in a table as wide as a campaign's.
//!
//! The sampler's threads wait while `record` and `checkpoint` run, so their time is what the
//! chain store costs a run; `finish` runs once, after sampling. Both the wall time of those
//! calls and the CPU time the calling thread spent in them are given: on a loaded machine the
//! wall time includes waiting for a core (and for the writer thread), the CPU time is the work
//! left on the sampler's thread.
//!
//! `cargo run --release --example sink_cost [-- COLUMNS STEPS WORK_US]` (default 500 value
//! columns, as a 50-contact campaign has, 2,000 steps of 4 ensembles of 32 walkers, and no
//! work between steps). WORK_US spins the calling thread that many microseconds per step, as
//! the density's evaluations would (a one-contact fit takes about 12,000 µs per step), so that
//! the writer thread works while the sampler does. Run it before and after a change to the
//! chain store to compare their cost on the sampler's thread.

use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use slipbayes::storage::{ChainFiles, ChainSink, ParquetSink, SinkOptions, StepView};

const ENSEMBLES: usize = 4;
const WALKERS: usize = 32;
const CHECKPOINT_EVERY: u64 = 200;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1).map(|a| a.parse::<usize>());
    let columns = args.next().transpose()?.unwrap_or(500);
    let steps = args.next().transpose()?.unwrap_or(2_000) as u64;
    let work = Duration::from_micros(args.next().transpose()?.unwrap_or(0) as u64);
    let dir = tempfile::tempdir()?;
    let files = ChainFiles {
        dir: dir.path().to_path_buf(),
        chains: dir.path().join("chains"),
        checkpoint: dir.path().join("checkpoint.bin"),
    };
    let params: Vec<String> = (0..columns - 1).map(|i| format!("p{i}")).collect();
    let mut sink = ParquetSink::create(&files, &params, &[], SinkOptions::default())?;

    // A step's draws are made before the clock starts: only the sink is timed.
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let positions: Vec<Vec<f64>> = (0..ENSEMBLES)
        .map(|_| (0..WALKERS * params.len()).map(|_| rng.random()).collect())
        .collect();
    let log_density: Vec<f64> = (0..WALKERS).map(|_| rng.random()).collect();
    let state = vec![0.5f64; ENSEMBLES * WALKERS * params.len()];

    let (mut record, mut checkpoint) = (Duration::ZERO, Duration::ZERO);
    let mut cpu = Duration::ZERO;
    let started = Instant::now();
    for step in 0..steps {
        let spin = Instant::now();
        while spin.elapsed() < work {
            std::hint::spin_loop();
        }
        for (ensemble, positions) in positions.iter().enumerate() {
            let view = StepView {
                ensemble,
                step,
                ndim: params.len(),
                positions,
                log_density: &log_density,
                derived: &[],
            };
            let (t, c) = (Instant::now(), thread_cpu());
            sink.record(&view)?;
            record += t.elapsed();
            cpu += thread_cpu() - c;
        }
        if (step + 1) % CHECKPOINT_EVERY == 0 {
            let (t, c) = (Instant::now(), thread_cpu());
            sink.checkpoint(&state)?;
            checkpoint += t.elapsed();
            cpu += thread_cpu() - c;
        }
    }
    let t = Instant::now();
    sink.finish()?;
    let finish = t.elapsed();
    let total = started.elapsed();

    let rows = steps * (ENSEMBLES * WALKERS) as u64;
    let bytes = rows * (16 + 8 * columns as u64);
    println!(
        "{columns} value columns, {steps} steps, {rows} rows ({:.0} MB of values), \
         checkpoint every {CHECKPOINT_EVERY} steps, {} us of work per step",
        bytes as f64 / 1e6,
        work.as_micros()
    );
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!("record      {:9.1} ms", ms(record));
    println!("checkpoint  {:9.1} ms", ms(checkpoint));
    println!(
        "sampler's thread waited {:.1} ms in all ({:.2} us per step)",
        ms(record + checkpoint),
        (record + checkpoint).as_secs_f64() * 1e6 / steps as f64
    );
    println!(
        "of which CPU time on the sampler's thread {:.1} ms ({:.2} us per step)",
        ms(cpu),
        cpu.as_secs_f64() * 1e6 / steps as f64
    );
    println!("finish      {:9.1} ms (once, after sampling)", ms(finish));
    println!("whole loop  {:9.1} ms", ms(total));
    Ok(())
}

/// CPU time of the calling thread.
fn thread_cpu() -> Duration {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid, writable timespec; the clock id is a constant the OS defines.
    let status = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    assert_eq!(status, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    Duration::new(t.tv_sec as u64, t.tv_nsec as u32)
}
