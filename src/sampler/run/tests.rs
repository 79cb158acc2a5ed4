use super::plan::blocks_of;
use super::*;
use crate::density::{
    BlockLinks, BlockPlan, BlockUpdate, BlockedDensity, IndependentBlocks, LogDensityError,
    OwnEntries, PlannedBlock, Target,
};
use crate::distributed::ReplicaShares;
use crate::sampler::{MemorySink, Move, NullSink, Silent};
use crate::sampler::{Parallelism, SamplerConfig, SamplerError, SamplerState, Steps, Updates};

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

/// Normal3 in two blocks with links as given, each updated by the moves, or as independent
/// blocks when `independent`.
struct Linked(Vec<BlockLinks>, bool);
impl LogDensity for Linked {
    fn dim(&self) -> usize {
        3
    }
    fn log_density(&self, x: &[f64], d: &mut [f64]) -> Result<f64, LogDensityError> {
        Normal3.log_density(x, d)
    }
}
impl BlockedDensity for Linked {
    fn state_len(&self) -> usize {
        0
    }
    fn log_density_with_state(
        &self,
        x: &[f64],
        d: &mut [f64],
        _state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        self.log_density(x, d)
    }
    fn log_density_after_block(
        &self,
        _block: usize,
        x: &[f64],
        d: &mut [f64],
        _state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        self.log_density(x, d)
    }
    fn block_plan(&self) -> BlockPlan<'_> {
        let blocks = [vec![0], vec![1, 2]]
            .into_iter()
            .zip(&self.0)
            .map(|(coords, links)| PlannedBlock {
                coords,
                links: links.clone(),
                update: if self.1 {
                    BlockUpdate::Independent {
                        own: self,
                        entries: OwnEntries::default(),
                    }
                } else {
                    BlockUpdate::Moves { carry: None }
                },
                split: None,
            })
            .collect();
        BlockPlan { blocks }
    }
}
impl IndependentBlocks for Linked {
    fn block_terms(&self, block: usize, x: &[f64], _state: &[f64]) -> f64 {
        let coords: &[usize] = if block == 0 { &[0] } else { &[1, 2] };
        coords.iter().map(|&i| -0.5 * x[i] * x[i]).sum()
    }
    fn update_block_state(
        &self,
        block: usize,
        x: &[f64],
        _d: &mut [f64],
        state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        Ok(self.block_terms(block, x, state))
    }
    fn log_density_from_state(&self, x: &[f64], d: &mut [f64], _state: &[f64]) -> f64 {
        Normal3.log_density(x, d).unwrap_or(f64::NAN)
    }
}

#[test]
fn hierarchical_updates_take_the_links_and_refuse_bad_ones() {
    let link = |given: Vec<usize>, followers: Vec<usize>| BlockLinks { given, followers };
    let config = |u| SamplerConfig::new(8, 1, 5).unwrap().with_updates(u);
    let good = Linked(vec![link(vec![], vec![1, 2]), link(vec![0], vec![])], false);
    let blocks = blocks_of(Target::blocked(&good), &config(Updates::Hierarchical)).unwrap();
    assert_eq!(blocks[0].links.followers, [1, 2]);
    assert_eq!(blocks[1].links.given, [0]);
    // Plain blocked updates ignore them.
    let blocks = blocks_of(Target::blocked(&good), &config(Updates::Blocked)).unwrap();
    assert!(blocks.iter().all(|b| b.links == BlockLinks::default()));
    // (A plan holds one entry of links per block: it cannot give another number of them.)
    for bad in [
        vec![link(vec![], vec![0]), link(vec![0], vec![])],
        vec![link(vec![], vec![3]), link(vec![0], vec![])],
    ] {
        match blocks_of(
            Target::blocked(&Linked(bad, false)),
            &config(Updates::Hierarchical),
        ) {
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
        self.log_density_with_state(x, d, &mut cache)
    }
}
impl BlockedDensity for Members {
    fn state_len(&self) -> usize {
        self.y.len()
    }
    fn log_density_with_state(
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
    fn log_density_after_block(
        &self,
        block: usize,
        x: &[f64],
        d: &mut [f64],
        cache: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        match self.order[block] {
            0 => self.log_density_with_state(x, d, cache),
            c => {
                cache[c - 1] = self.member(c - 1, x);
                Ok(self.total(x, cache, d))
            }
        }
    }
    fn block_plan(&self) -> BlockPlan<'_> {
        let blocks = self
            .order
            .iter()
            .map(|&c| PlannedBlock {
                coords: vec![c],
                links: BlockLinks::default(),
                update: match c {
                    0 => BlockUpdate::Moves { carry: None },
                    c => BlockUpdate::Independent {
                        own: self,
                        entries: OwnEntries {
                            state: vec![c - 1],
                            derived: Vec::new(),
                        },
                    },
                },
                split: None,
            })
            .collect();
        BlockPlan { blocks }
    }
}
impl IndependentBlocks for Members {
    fn block_terms(&self, _block: usize, _x: &[f64], state: &[f64]) -> f64 {
        state[0]
    }
    fn update_block_state(
        &self,
        block: usize,
        x: &[f64],
        _d: &mut [f64],
        state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        state[0] = self.member(self.order[block] - 1, x);
        Ok(state[0])
    }
    fn log_density_from_state(&self, x: &[f64], d: &mut [f64], cache: &[f64]) -> f64 {
        self.total(x, cache, d)
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
        let mut replicas = ReplicaShares::new(Target::blocked(&density), &config, shares).unwrap();
        let mut s = EnsembleSampler::new(Target::blocked(&density), config, init.clone()).unwrap();
        if shares > 1 {
            s.set_parallelism(Parallelism::from(&mut replicas));
        }
        s.run(Steps::Fixed(40), &mut NullSink, &mut Silent).unwrap();
        let blocks = s.blocks.iter().filter(|b| b.independent()).count();
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
    let density = Linked(vec![link(vec![], vec![1, 2]), link(vec![0], vec![])], true);
    let config = SamplerConfig::new(8, 1, 5)
        .unwrap()
        .with_updates(Updates::Hierarchical);
    match blocks_of(Target::blocked(&density), &config) {
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

/// Evaluates a batch as another process would: each item from copies of its inputs (the
/// point, and for a block update what it carries of its walker's state), stored back through
/// `set_outcome`, the later items in reverse order; the first third stays here.
struct Elsewhere<'d, D: ?Sized>(&'d D);

impl<D: LogDensity + ?Sized> crate::sampler::Executor for Elsewhere<'_, D> {
    fn evaluate(&mut self, batch: &mut crate::sampler::Batch<'_>) {
        let here = batch.len() / 3;
        batch.evaluate_here(0..here);
        for k in (here..batch.len()).rev() {
            let x = batch.point(k).to_vec();
            let (mut derived, mut state) = if batch.kind().reads_state() {
                (batch.derived(k).to_vec(), batch.cache(k).to_vec())
            } else {
                (vec![0.0; batch.nderived()], vec![0.0; batch.cache_len()])
            };
            let result = batch.kind().evaluate(self.0, &x, &mut derived, &mut state);
            batch.set_outcome(k, result, &derived, &state);
        }
    }

    fn run_shares(&self) -> usize {
        1
    }

    fn send_run(&mut self, _request: &super::RunRequest) {}

    fn gather_run(&mut self) -> Vec<super::RunOutcome> {
        Vec::new()
    }
}

/// A sampler whose evaluations go elsewhere (an MPI job's ranks) gives the same chains, bit
/// for bit, under joint, blocked and hierarchical updates, the members' blocks updated on
/// their own state.
#[test]
fn evaluations_made_elsewhere_give_the_same_chains() {
    let density = Members {
        y: vec![0.3, -1.2, 2.0, 0.7],
        order: vec![0, 1, 2, 3, 4],
    };
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
    for updates in [Updates::Joint, Updates::Blocked, Updates::Hierarchical] {
        let config = SamplerConfig::new(12, 2, 5)
            .unwrap()
            .with_updates(updates)
            .with_moves(vec![(Move::stretch(), 1.0), (Move::walk(), 1.0)])
            .unwrap();
        let mut alone =
            EnsembleSampler::new(Target::blocked(&density), config.clone(), init.clone()).unwrap();
        alone
            .run(Steps::Fixed(40), &mut NullSink, &mut Silent)
            .unwrap();
        let mut elsewhere = Elsewhere(&density);
        let mut there =
            EnsembleSampler::new(Target::blocked(&density), config, init.clone()).unwrap();
        there.set_parallelism(Parallelism::through(&mut elsewhere));
        there
            .run(Steps::Fixed(40), &mut NullSink, &mut Silent)
            .unwrap();
        assert!(there.state() == alone.state(), "{}", updates.as_str());
    }
}
