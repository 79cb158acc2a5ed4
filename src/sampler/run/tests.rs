use super::plan::blocks_of;
use super::*;
use crate::density::{BlockLinks, LogDensityError};
use crate::sampler::{MemorySink, Move, NullSink, Silent};
use crate::sampler::{ReplicaShares, SamplerConfig, SamplerError, SamplerState, Steps, Updates};

/// A 3-D standard normal without derived values.
struct Normal3;
impl LogDensity for Normal3 {
    fn dim(&self) -> usize {
        3
    }
    fn log_density(&self, x: &[f64], _d: &mut [f64]) -> Result<f64, LogDensityError> {
        Ok(-0.5 * x.iter().map(|v| v * v).sum::<f64>())
    }
}

/// Normal3 in two blocks with links as given.
struct Linked(Vec<BlockLinks>);
impl LogDensity for Linked {
    fn dim(&self) -> usize {
        3
    }
    fn log_density(&self, x: &[f64], d: &mut [f64]) -> Result<f64, LogDensityError> {
        Normal3.log_density(x, d)
    }
    fn blocks(&self) -> Vec<Vec<usize>> {
        vec![vec![0], vec![1, 2]]
    }
    fn block_links(&self) -> Vec<BlockLinks> {
        self.0.clone()
    }
}

#[test]
fn hierarchical_updates_take_the_links_and_refuse_bad_ones() {
    let link = |given: Vec<usize>, followers: Vec<usize>| BlockLinks { given, followers };
    let config = |u| SamplerConfig::new(8, 1, 5).unwrap().with_updates(u);
    let good = Linked(vec![link(vec![], vec![1, 2]), link(vec![0], vec![])]);
    let blocks = blocks_of(&good, &config(Updates::Hierarchical)).unwrap();
    assert_eq!(blocks[0].links.followers, [1, 2]);
    assert_eq!(blocks[1].links.given, [0]);
    // Plain blocked updates ignore them.
    let blocks = blocks_of(&good, &config(Updates::Blocked)).unwrap();
    assert!(blocks.iter().all(|b| b.links == BlockLinks::default()));
    for bad in [
        vec![link(vec![], vec![1, 2])],
        vec![link(vec![], vec![0]), link(vec![0], vec![])],
        vec![link(vec![], vec![3]), link(vec![0], vec![])],
    ] {
        match blocks_of(&Linked(bad), &config(Updates::Hierarchical)) {
            Err(SamplerError::InvalidConfig { name, .. }) => assert_eq!(name, "block_links"),
            other => panic!("expected bad block_links, got {other:?}"),
        }
    }
}

fn sampler(ensembles: usize) -> EnsembleSampler<'static, Normal3> {
    let config = SamplerConfig::new(8, ensembles, 5)
        .unwrap()
        .with_moves(vec![
            (Move::stretch(), 1.0),
            (Move::differential_evolution(), 1.0),
            (Move::walk(), 1.0),
        ])
        .unwrap();
    let init: Vec<Vec<Vec<f64>>> = (0..ensembles)
        .map(|e| {
            (0..8)
                .map(|w| {
                    let w = w as f64;
                    vec![
                        0.1 * w,
                        0.05 * ((3.0 * w + e as f64) % 8.0),
                        0.02 * (5.0 * w % 8.0),
                    ]
                })
                .collect()
        })
        .collect();
    EnsembleSampler::new(&Normal3, config, init).unwrap()
}

/// The stored log-density of every walker is the density at its position, from the
/// start (a density without derived values once left them all at 0) and after each step.
#[test]
fn stored_log_density_matches_the_position() {
    let mut s = sampler(2);
    for step in 0..=40 {
        if step > 0 {
            s.run(Steps::Fixed(1), &mut NullSink, &mut Silent).unwrap();
        }
        for (e, ens) in s.ensembles.iter().enumerate() {
            for (w, (x, &stored)) in ens
                .s
                .positions
                .chunks(3)
                .zip(&ens.s.log_density)
                .enumerate()
            {
                let lp = Normal3.log_density(x, &mut []).unwrap();
                assert!(
                    (lp - stored).abs() <= 1e-12,
                    "step {step}, ensemble {e}, walker {w}: stored {stored}, density {lp}"
                );
            }
        }
    }
}

/// A hierarchical normal: μ ~ N(0, 3²) shared, members θ_j ~ N(μ, 1) each observed once
/// (y_j ~ N(θ_j, 0.5²)), in blocks listed in `order` (μ's first). The cache holds each
/// member's terms; the members' blocks are independent given μ. One derived value, the
/// sum of the coordinates, reads the whole point.
struct Members {
    y: Vec<f64>,
    order: Vec<usize>,
}
impl Members {
    fn member(&self, j: usize, x: &[f64]) -> f64 {
        let (t, r) = (x[j + 1] - x[0], (self.y[j] - x[j + 1]) / 0.5);
        -0.5 * (t * t + r * r)
    }
    fn total(&self, x: &[f64], cache: &[f64], derived: &mut [f64]) -> f64 {
        derived[0] = x.iter().sum();
        cache.iter().fold(-0.5 * x[0] * x[0] / 9.0, |lp, c| lp + c)
    }
}
impl LogDensity for Members {
    fn dim(&self) -> usize {
        self.y.len() + 1
    }
    fn derived_names(&self) -> Vec<String> {
        vec!["sum".into()]
    }
    fn log_density(&self, x: &[f64], d: &mut [f64]) -> Result<f64, LogDensityError> {
        let mut cache = vec![0.0; self.y.len()];
        self.log_density_cached(x, d, &mut cache)
    }
    fn blocks(&self) -> Vec<Vec<usize>> {
        self.order.iter().map(|&b| vec![b]).collect()
    }
    fn independent_blocks(&self) -> Vec<usize> {
        (0..self.order.len())
            .filter(|&b| self.order[b] != 0)
            .collect()
    }
    fn block_log_density(&self, block: usize, _x: &[f64], cache: &[f64]) -> f64 {
        cache[self.order[block] - 1]
    }
    fn log_density_from_cache(&self, x: &[f64], derived: &mut [f64], cache: &[f64]) -> Option<f64> {
        Some(self.total(x, cache, derived))
    }
    fn cache_len(&self) -> usize {
        self.y.len()
    }
    fn log_density_cached(
        &self,
        x: &[f64],
        d: &mut [f64],
        cache: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        for (j, c) in cache.iter_mut().enumerate() {
            *c = self.member(j, x);
        }
        Ok(self.total(x, cache, d))
    }
    fn log_density_block(
        &self,
        block: usize,
        x: &[f64],
        d: &mut [f64],
        cache: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        match self.order[block] {
            0 => self.log_density_cached(x, d, cache),
            c => {
                cache[c - 1] = self.member(c - 1, x);
                Ok(self.total(x, cache, d))
            }
        }
    }
}

/// The members' blocks are updated in whatever order the density lists them with the
/// same chains, bit for bit, under every kind of move: each draws from streams keyed by
/// its first coordinate and accepts on its own terms.
#[test]
fn independent_blocks_give_the_same_chains_in_any_order() {
    let y = vec![0.3, -1.2, 2.0, 0.7];
    let init: Vec<Vec<Vec<f64>>> = (0..2)
        .map(|e| {
            (0..12)
                .map(|w| {
                    (0..5)
                        .map(|i| 0.1 * ((w * 7 + i * 3 + e) % 11) as f64 - 0.5)
                        .collect()
                })
                .collect()
        })
        .collect();
    // Updated in `shares` shares, all but the first on replicas (1: not split).
    let run_split = |order: Vec<usize>, moves: Vec<(Move, f64)>, shares: usize| {
        let density = Members {
            y: y.clone(),
            order,
        };
        let config = SamplerConfig::new(12, 2, 11)
            .unwrap()
            .with_updates(Updates::Blocked)
            .with_moves(moves)
            .unwrap();
        let mut replicas = ReplicaShares::new(&density, &config, shares).unwrap();
        let mut s = EnsembleSampler::new(&density, config, init.clone()).unwrap();
        if shares > 1 {
            s.set_offload(&mut replicas);
        }
        s.run(Steps::Fixed(40), &mut NullSink, &mut Silent).unwrap();
        let blocks = s.blocks.iter().filter(|b| b.independent).count();
        assert_eq!(blocks, 4);
        s.ensembles
            .iter()
            .map(|e| {
                (
                    (
                        e.s.positions.clone(),
                        e.s.log_density.clone(),
                        e.s.derived.clone(),
                    ),
                    (
                        e.s.accepted.clone(),
                        e.s.evaluations,
                        e.s.slice_scales.clone(),
                        e.s.slice_updates,
                    ),
                )
            })
            .collect::<Vec<_>>()
    };
    // The slice move's scales are kept per block in the blocks' order: left out here.
    let run = |order: Vec<usize>, moves: Vec<(Move, f64)>| {
        let mut chains = run_split(order, moves, 1);
        for (_, (_, _, scales, _)) in &mut chains {
            scales.clear();
        }
        chains
    };
    for moves in [
        vec![
            (Move::stretch(), 1.0),
            (Move::differential_evolution(), 1.0),
        ],
        vec![(Move::student_t(), 1.0)],
        vec![(Move::slice(), 1.0)],
    ] {
        let listed = run(vec![0, 1, 2, 3, 4], moves.clone());
        for order in [vec![0, 4, 3, 2, 1], vec![0, 2, 4, 1, 3]] {
            assert_eq!(run(order, moves.clone()), listed, "moves {moves:?}");
        }
        // Updated at the same time in shares on replicas, merged: the same bits.
        let whole = run_split(vec![0, 1, 2, 3, 4], moves.clone(), 1);
        for shares in [2, 3, 4] {
            let split = run_split(vec![0, 1, 2, 3, 4], moves.clone(), shares);
            assert_eq!(split, whole, "moves {moves:?}, {shares} shares");
        }
        // The walkers did move.
        let start: Vec<f64> = init[0].concat();
        assert!(listed[0]
            .0
             .0
            .iter()
            .zip(&start)
            .any(|(a, b)| a.to_bits() != b.to_bits()));
    }
}

/// A block named independent that has followers, or is drawn exactly, is refused.
#[test]
fn independent_blocks_with_followers_are_refused() {
    let link = |given: Vec<usize>, followers: Vec<usize>| BlockLinks { given, followers };
    struct Claims(Linked);
    impl LogDensity for Claims {
        fn dim(&self) -> usize {
            3
        }
        fn log_density(&self, x: &[f64], d: &mut [f64]) -> Result<f64, LogDensityError> {
            self.0.log_density(x, d)
        }
        fn blocks(&self) -> Vec<Vec<usize>> {
            self.0.blocks()
        }
        fn block_links(&self) -> Vec<BlockLinks> {
            self.0.block_links()
        }
        fn independent_blocks(&self) -> Vec<usize> {
            vec![0, 1]
        }
    }
    let density = Claims(Linked(vec![
        link(vec![], vec![1, 2]),
        link(vec![0], vec![]),
    ]));
    let config = SamplerConfig::new(8, 1, 5)
        .unwrap()
        .with_updates(Updates::Hierarchical);
    match blocks_of(&density, &config) {
        Err(SamplerError::InvalidConfig { name, .. }) => assert_eq!(name, "independent_blocks"),
        other => panic!("expected refused independent_blocks, got {other:?}"),
    }
}

/// A checkpoint serialises the borrowed view exactly like the owned state.
#[test]
fn checkpoint_view_serialises_like_the_state() {
    let mut s = sampler(2);
    let mut sink = MemorySink::new();
    s.run(Steps::Fixed(30), &mut sink, &mut Silent).unwrap();
    let mut state = s.state();
    let history = state.history.take();
    assert_eq!(
        sink.last_checkpoint.as_deref(),
        Some(serde_json::to_string(&state).unwrap().as_str())
    );
    // What the checkpoint leaves out, the chains restore bit for bit.
    let mut restored: SamplerState =
        serde_json::from_str(sink.last_checkpoint.as_deref().unwrap()).unwrap();
    restored
        .rebuild_history::<SamplerError>(&s.config, |p| Ok(sink.position_column(p)))
        .unwrap();
    assert_eq!(restored.history, history);
}
