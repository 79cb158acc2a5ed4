//! Hostile inputs without cargo-fuzz: every fuzz target of fuzz/ (tests/hostile/) run over a
//! few thousand seeded mutations of its seeds (truncations at every length of the small
//! seeds, byte flips and overwrites, splices of two seeds, inserted and deleted runs), and
//! over every input the fuzzers once crashed on (tests/fuzz-regressions/<target>/). A panic
//! is caught only to be reported: every target must read or refuse each input with an error
//! naming the file, and panic on none.
#![cfg(all(feature = "parquet", feature = "tabular"))]

mod hostile;

use std::path::{Path, PathBuf};

use hostile::{Scratch, TARGETS};

/// Mutated inputs tried per target (on top of the seeds and the truncations).
const MUTATIONS: usize = 3000;
/// Seeds up to this size are also cut at every length; longer ones at this many lengths.
const TRUNCATE_ALL_UP_TO: usize = 4096;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

/// SplitMix64: the mutations are the same on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Bytes a parser gives meaning to, for overwrites and insertions.
const INTERESTING: &[u8] = b"\0\xff\n\r\t,;.-+eE09\"[]{}=:#PAR1";

/// One mutation of `seeds[k]`, possibly spliced with another seed.
fn mutate(rng: &mut Rng, seeds: &[Vec<u8>]) -> Vec<u8> {
    let mut data = seeds[rng.below(seeds.len())].clone();
    for _ in 0..1 + rng.below(4) {
        let len = data.len();
        match rng.below(6) {
            0 if len > 0 => {
                let i = rng.below(len);
                data[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                data[i] = INTERESTING[rng.below(INTERESTING.len())];
            }
            2 => {
                let other = &seeds[rng.below(seeds.len())];
                let (a, b) = (rng.below(len + 1), rng.below(other.len() + 1));
                data.truncate(a);
                data.extend_from_slice(&other[b..]);
            }
            3 => {
                let i = rng.below(len + 1);
                let run: Vec<u8> = (0..1 + rng.below(8))
                    .map(|_| INTERESTING[rng.below(INTERESTING.len())])
                    .collect();
                data.splice(i..i, run);
            }
            4 if len > 0 => {
                let i = rng.below(len);
                let end = (i + 1 + rng.below(16)).min(len);
                data.drain(i..end);
            }
            _ if len > 0 => {
                // A run of the input repeated: long lines, repeated headers and blocks.
                let i = rng.below(len);
                let end = (i + 1 + rng.below(64)).min(len);
                let copy = data[i..end].to_vec();
                data.splice(i..i, copy);
            }
            _ => data.push(INTERESTING[rng.below(INTERESTING.len())]),
        }
    }
    data
}

/// The seeds of target `name`: its folder of fuzz/seeds/ (those of `checkpoint` and
/// `chain_part` are the files of [`Scratch`]'s template store).
fn seeds(name: &str) -> Vec<Vec<u8>> {
    let seeds: Vec<Vec<u8>> = match std::fs::read_dir(repo("fuzz/seeds").join(name)) {
        Ok(entries) => entries
            .map(|e| std::fs::read(e.unwrap().path()).unwrap())
            .collect(),
        Err(_) => Vec::new(),
    };
    assert!(!seeds.is_empty(), "no seeds for target {name}");
    seeds
}

/// Runs `name` on `input`, returning the panic message if it panicked.
fn try_one(name: &str, scratch: &Scratch, input: &[u8]) -> Option<String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        hostile::run(name, scratch, input);
    }))
    .err()
    .map(|p| {
        p.downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| (*s).to_owned()))
            .unwrap_or_default()
    })
}

/// Runs target `name` on its seeds, their truncations and `MUTATIONS` mutations; returns the
/// inputs tried and the failures (saved under target/hostile-failures/<name>/).
fn exercise(name: &str) -> (usize, Vec<String>) {
    let tmp = tempfile::tempdir().unwrap();
    let scratch = Scratch::new(tmp.path());
    let seeds = seeds(name);
    let mut inputs: Vec<Vec<u8>> = seeds.clone();
    for seed in &seeds {
        let step = (seed.len() / TRUNCATE_ALL_UP_TO).max(1);
        inputs.extend((0..seed.len()).step_by(step).map(|n| seed[..n].to_vec()));
    }
    let mut rng = Rng(name.bytes().fold(0x5eed, |h, b| h * 31 + u64::from(b)));
    inputs.extend((0..MUTATIONS).map(|_| mutate(&mut rng, &seeds)));
    let mut failures = Vec::new();
    for (i, input) in inputs.iter().enumerate() {
        if let Some(message) = try_one(name, &scratch, input) {
            let dir = repo("target/hostile-failures").join(name);
            std::fs::create_dir_all(&dir).unwrap();
            let path = dir.join(format!("input-{i}"));
            std::fs::write(&path, input).unwrap();
            failures.push(format!("{name}: {} ({message})", path.display()));
        }
    }
    (inputs.len(), failures)
}

fn check_target(name: &str) {
    let (tried, failures) = exercise(name);
    println!("{name}: {tried} inputs, {} failures", failures.len());
    assert!(tried >= MUTATIONS, "{name}: {tried} inputs");
    assert!(
        failures.is_empty(),
        "{} of {tried} inputs broke target {name}:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

macro_rules! targets {
    ($($name:ident),* $(,)?) => {
        $(
            #[test]
            fn $name() {
                check_target(stringify!($name));
            }
        )*

        #[test]
        fn every_target_is_exercised() {
            let mut listed = vec![$(stringify!($name)),*];
            listed.sort_unstable();
            let mut all = TARGETS.to_vec();
            all.sort_unstable();
            assert_eq!(listed, all);
        }
    };
}

targets!(
    csv,
    simple_csv,
    rheocompass,
    trios,
    rspace,
    parquet,
    model_toml,
    model_dict,
    run_files,
    checkpoint,
    chain_part,
);

/// Every input a fuzz target once crashed on, replayed through its target
/// (tests/fuzz-regressions/<target>/).
#[test]
fn fuzz_regressions_replay_through_their_targets() {
    let tmp = tempfile::tempdir().unwrap();
    let scratch = Scratch::new(tmp.path());
    let mut failures = Vec::new();
    for name in TARGETS {
        let Ok(entries) = std::fs::read_dir(repo("tests/fuzz-regressions").join(name)) else {
            continue;
        };
        for entry in entries {
            let path = entry.unwrap().path();
            let input = std::fs::read(&path).unwrap();
            if let Some(message) = try_one(name, &scratch, &input) {
                failures.push(format!("{}: {message}", path.display()));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
