//! The friction posterior's blocks: one per contact for its own parameters and one per
//! material for what its contacts share; and a block update, reusing the cache of the point
//! it starts from, gives exactly (bit for bit) the log-density, derived values and cache of a
//! full evaluation. Checked on the demo model and on the variants a model file allows: t0
//! pooling, `aging = "absolute"`, σ sampled rather than integrated out, t0 per contact.

use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use slipbayes::density::{
    BlockLinks, BlockPlan, BlockUpdate, BlockedDensity, CarriedMove, CarryFollowers,
    ExactConditional, IndependentBlocks, LogDensity, LogDensityError, OwnEntries, PlannedBlock,
    ShareError, SplitByPart, Target,
};
use slipbayes::distributed::ReplicaShares;
use slipbayes::model::Posterior;
use slipbayes::run_file::RunFile;
use slipbayes::sampler::{
    EnsembleSampler, MemorySink, Move, Parallelism, SamplerConfig, Silent, Steps, Updates,
};

/// The coordinates of each block of the posterior's plan.
fn blocks_of(post: &Posterior) -> Vec<Vec<usize>> {
    post.block_plan().coords()
}

/// The links of each block of the posterior's plan.
fn links_of(post: &Posterior) -> Vec<BlockLinks> {
    post.block_plan()
        .blocks
        .into_iter()
        .map(|b| b.links)
        .collect()
}

/// The blocks of the plan updated as independent blocks, with their own entries.
fn own_entries(post: &Posterior) -> Vec<(usize, OwnEntries)> {
    post.block_plan()
        .blocks
        .into_iter()
        .enumerate()
        .filter_map(|(b, block)| match block.update {
            BlockUpdate::Independent { entries, .. } => Some((b, entries)),
            _ => None,
        })
        .collect()
}

/// The blocks of the plan updated as independent blocks.
fn independent_of(post: &Posterior) -> Vec<usize> {
    own_entries(post).into_iter().map(|(b, _)| b).collect()
}

/// The blocks of the plan drawn exactly.
fn exact_of(post: &Posterior) -> Vec<usize> {
    let plan = post.block_plan();
    (0..plan.blocks.len())
        .filter(|&b| matches!(plan.blocks[b].update, BlockUpdate::Exact { .. }))
        .collect()
}

/// Whether block `b` of the plan carries its followers along the density's map.
fn carries(post: &Posterior, b: usize) -> bool {
    match &post.block_plan().blocks[b].update {
        BlockUpdate::Exact { carry, .. } => carry.is_some(),
        BlockUpdate::Moves { carry } => carry.is_some(),
        BlockUpdate::Independent { .. } => false,
    }
}

/// Whether an update of block `b` of the plan splits by independent block.
fn splits(post: &Posterior, b: usize) -> bool {
    post.block_plan().blocks[b].split.is_some()
}

/// Block `b`'s own entries of `values`, gathered as the sampler gathers them.
fn gather(entries: &[usize], values: &[f64]) -> Vec<f64> {
    entries.iter().map(|&e| values[e]).collect()
}

/// The terms of independent block `b` at `x` from a walker's whole `cache`.
fn own_terms(post: &Posterior, b: usize, x: &[f64], cache: &[f64]) -> f64 {
    let entries = &own_entries(post)
        .into_iter()
        .find(|(k, _)| *k == b)
        .unwrap()
        .1;
    post.block_terms(b, x, &gather(&entries.state, cache))
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The demo model with `extra` (top-level keys, then tables) added and `blocks` in its
/// `[sampler]` table, its data paths made absolute.
fn demo_variant(dir: &Path, name: &str, extra: &str, blocks: &str) -> Posterior {
    let text = std::fs::read_to_string(root().join("models/demo.toml"))
        .unwrap()
        .replace("../data/", &format!("{}/", root().join("data").display()))
        .replace(
            "[sampler]\n",
            &format!("[sampler]\nblocks = \"{blocks}\"\n"),
        );
    let path = dir.join(name);
    // Top-level keys must come before the first table.
    let (top, tables) = match extra.find('[') {
        Some(i) => extra.split_at(i),
        None => (extra, ""),
    };
    std::fs::write(&path, format!("{top}\n{text}\n{tables}\n")).unwrap();
    let spec = RunFile::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
    spec.posterior().unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// From points near the start, moves one block at a time (with its followers) and compares
/// the block update with a full evaluation at the new point.
fn check_block_updates(label: &str, post: &Posterior) {
    let blocks = blocks_of(post);
    let links = links_of(post);
    let (nd, nc) = (post.derived_names().len(), post.state_len());
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut x = post.start().to_vec();
    let mut derived = vec![0.0; nd];
    let mut cache = vec![0.0; nc];
    let mut lp = post
        .log_density_with_state(&x, &mut derived, &mut cache)
        .unwrap_or_else(|e| panic!("{label}: start {e}"));
    let mut checked = 0;
    for round in 0..40 {
        let b = round % blocks.len();
        let mut y = x.clone();
        for &i in blocks[b].iter().chain(&links[b].followers) {
            y[i] += 0.01 * rng.random::<f64>() - 0.005;
        }
        let (mut d_block, mut c_block) = (derived.clone(), cache.clone());
        let block = post.log_density_after_block(b, &y, &mut d_block, &mut c_block);
        let (mut d_full, mut c_full) = (vec![0.0; nd], vec![0.0; nc]);
        let full = post.log_density_with_state(&y, &mut d_full, &mut c_full);
        match (block, full) {
            (Ok(a), Ok(f)) => {
                assert!(same(a, f), "{label}: block {b}: {a} vs full {f}");
                for (k, (u, v)) in d_block.iter().zip(&d_full).enumerate() {
                    assert!(same(*u, *v), "{label}: block {b}: derived {k}: {u} vs {v}");
                }
                for (k, (u, v)) in c_block.iter().zip(&c_full).enumerate() {
                    assert!(same(*u, *v), "{label}: block {b}: cache {k}: {u} vs {v}");
                }
                // An independent block's own terms change exactly as the density does.
                if independent_of(post).contains(&b) {
                    let change = own_terms(post, b, &y, &c_block) - own_terms(post, b, &x, &cache);
                    assert!(
                        ((a - lp) - change).abs() <= 1e-9 * lp.abs().max(1.0),
                        "{label}: block {b}: its terms change by {change}, the density by {}",
                        a - lp
                    );
                    check_own_update(label, post, b, &y, (&derived, &cache), (&d_block, &c_block));
                }
                (x, derived, cache, lp) = (y, d_block, c_block, a);
                checked += 1;
            }
            (Err(a), Err(f)) => assert_eq!(a, f, "{label}: block {b}"),
            (a, f) => panic!("{label}: block {b}: block update {a:?}, full {f:?}"),
        }
    }
    assert!(checked >= 30, "{label}: only {checked} points evaluated");
    assert!(lp.is_finite());
    // From the cache alone: the same log-density and derived values, bit for bit.
    let mut d_cache = derived.clone();
    d_cache.iter_mut().for_each(|d| *d = -1.0);
    let from_cache = Some(post.log_density_from_state(&x, &mut d_cache, &cache));
    assert_eq!(from_cache.map(f64::to_bits), Some(lp.to_bits()), "{label}");
    for (k, (u, v)) in d_cache.iter().zip(&derived).enumerate() {
        // Only the values that belong to no one block are rewritten.
        assert!(
            same(*u, *v) || *u == -1.0,
            "{label}: derived {k}: {u} vs {v}"
        );
    }
    check_conditional_blocks(label, post, &x);
    check_split_updates(label, post, &x, &derived, &cache);
    check_held_shares(label, post, &x, &derived, &cache);
    assert_eq!(
        post.log_density(&x, &mut derived).unwrap().to_bits(),
        lp.to_bits()
    );
}

/// Independent block `b`'s update on its own entries alone, gathered from the walker's
/// derived values and cache `from` (as the sampler gathers them), moved to `y`: the same bits,
/// entry for entry, as the whole update that left `to`, and its terms those of `to`.
fn check_own_update(
    label: &str,
    post: &Posterior,
    b: usize,
    y: &[f64],
    from: (&[f64], &[f64]),
    to: (&[f64], &[f64]),
) {
    let entries = own_entries(post)
        .into_iter()
        .find(|(k, _)| *k == b)
        .unwrap()
        .1;
    let mut state = gather(&entries.state, from.1);
    let mut derived = gather(&entries.derived, from.0);
    let terms = post
        .update_block_state(b, y, &mut derived, &mut state)
        .unwrap_or_else(|e| panic!("{label}: block {b}: {e}"));
    assert!(
        same(terms, own_terms(post, b, y, to.1)),
        "{label}: block {b}"
    );
    for (k, (&e, v)) in entries.state.iter().zip(&state).enumerate() {
        assert!(
            same(*v, to.1[e]),
            "{label}: block {b}: state {k}: {v} vs {}",
            to.1[e]
        );
    }
    for (&e, v) in entries.derived.iter().zip(&derived) {
        assert!(
            same(*v, to.0[e]),
            "{label}: block {b}: derived {e}: {v} vs {}",
            to.0[e]
        );
    }
}

/// An update of block `b` at `y` split into `shares` shares of the independent blocks, as the
/// ranks of an MPI job split it: the first share in place on the walker's derived values and
/// cache, the others on buffers of NaN (a share must read nothing it does not compute) whose
/// entries are then merged, and the rest finished from the merged cache.
/// The other shares are evaluated by `apart` (share r by `apart[r - 1]`: the whole posterior,
/// or the share of it that holds only share r's data).
fn split_update(
    post: &Posterior,
    apart: &[&Posterior],
    b: usize,
    y: &[f64],
    derived: &mut [f64],
    cache: &mut [f64],
) -> Result<f64, LogDensityError> {
    let (parts, shares) = (independent_of(post).len(), apart.len() + 1);
    let share = |r: usize| parts * r / shares..parts * (r + 1) / shares;
    let mut failure = post.evaluate_share(b, share(0), y, derived, cache).err();
    for r in 1..shares {
        let (mut d, mut c) = (vec![f64::NAN; derived.len()], vec![f64::NAN; cache.len()]);
        match apart[r - 1].evaluate_share(b, share(r), y, &mut d, &mut c) {
            Ok(()) => {
                let OwnEntries {
                    state: c_entries,
                    derived: d_entries,
                } = post.share_entries(b, share(r));
                d_entries.iter().for_each(|&j| derived[j] = d[j]);
                c_entries.iter().for_each(|&j| cache[j] = c[j]);
            }
            Err(e) => ShareError::keep_first(&mut failure, e),
        }
    }
    match failure {
        Some(f) => Err(f.error),
        None => Ok(post.log_density_from_shares(b, y, derived, cache)),
    }
}

/// `post` cut `shares` ways as the ranks of an MPI job hold it: per share, the posterior that
/// holds only the data of its independent blocks' runs; `None` when the model's updates need
/// every run on every rank.
fn data_shares(post: &Posterior, shares: usize) -> Option<Vec<Posterior>> {
    let data_share = post.data_share()?;
    let own = |r: usize| move |parts: usize| parts * r / shares..parts * (r + 1) / shares;
    Some(
        (0..shares)
            .map(|r| {
                Posterior::share_of(post.spec(), post.blocking(), &data_share, own(r)).unwrap()
            })
            .collect(),
    )
}

/// Where the model lets each rank hold only its contacts' data: the shares hold every run once
/// between them, each fewer than all; a share updates its own independent blocks with the
/// whole posterior's bits (log-density, derived values, cache) and refuses another's, naming
/// the run it does not hold.
fn check_held_shares(label: &str, post: &Posterior, x: &[f64], derived: &[f64], cache: &[f64]) {
    let (blocks, links) = (blocks_of(post), links_of(post));
    let independent = independent_of(post);
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    for shares in [2, 3] {
        let Some(own) = data_shares(post, shares) else {
            return;
        };
        let runs = post.held_runs().1;
        let held: Vec<usize> = own.iter().map(|p| p.held_runs().0).collect();
        assert_eq!(held.iter().sum::<usize>(), runs, "{label}: {held:?}");
        assert!(held.iter().all(|&h| h < runs), "{label}: {held:?}");
        let parts = independent.len();
        for (r, share_post) in own.iter().enumerate() {
            let mine = parts * r / shares..parts * (r + 1) / shares;
            for (k, &b) in independent.iter().enumerate() {
                let mut y = x.to_vec();
                for &i in blocks[b].iter().chain(&links[b].followers) {
                    y[i] += 0.01 * rng.random::<f64>() - 0.005;
                }
                let (mut d_whole, mut c_whole) = (derived.to_vec(), cache.to_vec());
                let whole = post.log_density_after_block(b, &y, &mut d_whole, &mut c_whole);
                let (mut d, mut c) = (derived.to_vec(), cache.to_vec());
                let held = share_post.log_density_after_block(b, &y, &mut d, &mut c);
                let at = format!("{label}: block {b}, share {r} of {shares}");
                if !mine.contains(&k) {
                    let Err(LogDensityError::Fatal { message }) = held else {
                        panic!("{at}: {held:?}");
                    };
                    assert!(message.contains("held by another rank"), "{at}: {message}");
                    continue;
                }
                let whole = whole.unwrap_or_else(|e| panic!("{at}: {e}"));
                assert_eq!(held.map(f64::to_bits), Ok(whole.to_bits()), "{at}");
                for (j, (u, v)) in d.iter().zip(&d_whole).enumerate() {
                    assert!(
                        same(*u, *v),
                        "{at}: {}: {u} vs {v}",
                        post.derived_names()[j]
                    );
                }
                assert!(c.iter().zip(&c_whole).all(|(u, v)| same(*u, *v)), "{at}");
            }
        }
    }
}

/// Every block whose update splits by independent block: split into 1, 2 and 3 shares, its
/// update from `x` gives the log-density, derived values and cache of the whole update bit for
/// bit, and where it fails (a coordinate moved far), the same failure.
fn check_split_updates(label: &str, post: &Posterior, x: &[f64], derived: &[f64], cache: &[f64]) {
    let blocks = blocks_of(post);
    let links = links_of(post);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    // Every other share evaluated by the whole posterior, then by one that holds only that
    // share's data (as the ranks of an MPI job hold them, where the model lets them).
    let held: Vec<(usize, Vec<Posterior>)> = (2..=3)
        .filter_map(|shares| Some((shares, data_shares(post, shares)?)))
        .collect();
    let mut tries: Vec<(usize, Vec<&Posterior>, &str)> = (1..=3)
        .map(|shares| (shares, vec![post; shares - 1], "whole"))
        .collect();
    tries.extend(
        held.iter()
            .map(|(shares, own)| (*shares, own[1..].iter().collect(), "its own data")),
    );
    for b in (0..blocks.len()).filter(|&b| splits(post, b)) {
        for far in [false, true] {
            let mut y = x.to_vec();
            for &i in blocks[b].iter().chain(&links[b].followers) {
                y[i] += 0.01 * rng.random::<f64>() - 0.005;
            }
            if far {
                y[blocks[b][0]] += 40.0;
            }
            let (mut d_whole, mut c_whole) = (derived.to_vec(), cache.to_vec());
            let whole = post.log_density_after_block(b, &y, &mut d_whole, &mut c_whole);
            assert_eq!(whole.is_err(), far, "{label}: block {b}: {whole:?}");
            for (shares, apart, holding) in &tries {
                let shares = *shares;
                let (mut d, mut c) = (derived.to_vec(), cache.to_vec());
                let split = split_update(post, apart, b, &y, &mut d, &mut c);
                let at = format!("{label}: block {b} in {shares} shares ({holding}), far {far}");
                match (&whole, &split) {
                    (Ok(w), Ok(s)) => {
                        assert_eq!(w.to_bits(), s.to_bits(), "{at}");
                        for (k, (u, v)) in d.iter().zip(&d_whole).enumerate() {
                            assert!(same(*u, *v), "{at}: derived {k}: {u} vs {v}");
                        }
                        for (k, (u, v)) in c.iter().zip(&c_whole).enumerate() {
                            assert!(same(*u, *v), "{at}: cache {k}: {u} vs {v}");
                        }
                    }
                    _ => assert_eq!(split, whole, "{at}"),
                }
            }
        }
    }
}

/// Each conditional block (a t0 population) at `x`: its conditional density changes as the
/// log-density does when only the block moves; the update of the block alone equals a full
/// evaluation bit for bit; the non-centred map keeps each member's standardised offset and
/// is its own inverse, with opposite Jacobians.
fn check_conditional_blocks(label: &str, post: &Posterior, x: &[f64]) {
    let (nd, nc) = (post.derived_names().len(), post.state_len());
    let blocks = blocks_of(post);
    let links = links_of(post);
    let (mut derived, mut cache) = (vec![0.0; nd], vec![0.0; nc]);
    let lp = post
        .log_density_with_state(x, &mut derived, &mut cache)
        .unwrap();
    // The search coordinates (non-centred) map back to the point, with the Jacobian of one
    // ln s per member.
    if let Some(map) = post.search_map() {
        let mut y = vec![0.0; x.len()];
        map.search_point(x, &mut y);
        let mut back = vec![0.0; x.len()];
        let ln_jacobian = map.density_point(&y, &mut back);
        assert!(
            x.iter().zip(&back).all(|(a, b)| (a - b).abs() < 1e-12),
            "{label}"
        );
        let members = x.iter().zip(&y).filter(|(a, b)| a != b).count();
        assert!(
            members > 0 && ln_jacobian != 0.0,
            "{label}: {members} members"
        );
    } else {
        assert!(exact_of(post).is_empty(), "{label}");
    }
    for b in exact_of(post) {
        // Every population of the block (μ, ln s pairs) moves: μ up, ln s down.
        let mut y = x.to_vec();
        for (k, &i) in blocks[b].iter().enumerate() {
            y[i] += if k % 2 == 0 { 0.3 } else { -0.4 };
        }
        let (mut d_alone, mut c_alone) = (derived.clone(), cache.clone());
        let alone = post
            .log_density_after_draw(b, &y, &mut d_alone, &mut c_alone)
            .unwrap();
        let (mut d_full, mut c_full) = (vec![0.0; nd], vec![0.0; nc]);
        let full = post
            .log_density_with_state(&y, &mut d_full, &mut c_full)
            .unwrap();
        assert!(
            same(alone, full),
            "{label}: block {b} alone: {alone} vs {full}"
        );
        assert!(d_alone.iter().zip(&d_full).all(|(u, v)| same(*u, *v)));
        assert!(c_alone.iter().zip(&c_full).all(|(u, v)| same(*u, *v)));
        let change = post.conditional_log_density(b, &y) - post.conditional_log_density(b, x);
        assert!(
            ((full - lp) - change).abs() <= 1e-9 * lp.abs(),
            "{label}: block {b}: the conditional changes by {change}, the density by {}",
            full - lp
        );
        // The non-centred map there and back, where the members follow the population: it
        // keeps every member's non-centred coordinate, with the search map's Jacobian.
        if !carries(post, b) {
            assert!(
                label.contains("by material"),
                "{label}: block {b} carries nothing"
            );
            continue;
        }
        let map = post.search_map().expect("a search map with populations");
        let mut there = y.clone();
        let jacobian = post.carry_followers(b, x, &mut there);
        let mut back = x.to_vec();
        let back_jacobian = post.carry_followers(b, &there, &mut back);
        assert_eq!(jacobian, -back_jacobian, "{label}: block {b}");
        assert!(
            x.iter().zip(&back).all(|(u, v)| (u - v).abs() < 1e-12),
            "{label}"
        );
        let (mut z_x, mut z_there) = (vec![0.0; x.len()], vec![0.0; x.len()]);
        map.search_point(x, &mut z_x);
        map.search_point(&there, &mut z_there);
        let moved: Vec<usize> = (0..x.len())
            .filter(|&i| there[i] != x[i] && !blocks[b].contains(&i))
            .collect();
        assert!(!moved.is_empty(), "{label}: block {b} carries nothing");
        assert!(links[b]
            .followers
            .iter()
            .all(|&i| (z_x[i] - z_there[i]).abs() < 1e-12));
        let mut scratch = vec![0.0; x.len()];
        let ln_j = |z: &[f64], s: &mut [f64]| map.density_point(z, s);
        let expected = ln_j(&z_there, &mut scratch) - ln_j(&z_x, &mut scratch);
        assert!(
            (jacobian - expected).abs() < 1e-9,
            "{label}: Jacobian {jacobian}, search map's {expected}"
        );
    }
}

fn names(post: &Posterior, block: &[usize]) -> Vec<String> {
    let names = post.param_names();
    block.iter().map(|&i| names[i].clone()).collect()
}

#[test]
fn demo_blocks_follow_materials_and_contacts() {
    let dir = tempfile::tempdir().unwrap();
    // By material (the default): one block per material, everything of its contacts in it.
    let post = demo_variant(dir.path(), "demo.toml", "", "material");
    let labelled: Vec<Vec<String>> = blocks_of(&post).iter().map(|b| names(&post, b)).collect();
    assert_eq!(labelled.len(), 2, "{labelled:?}");
    let ptfe = labelled
        .iter()
        .find(|b| b.iter().any(|n| n == "ln_alpha[PTFE]"))
        .unwrap();
    for member in [
        "ln_a_over_F_d[PTFE]",
        "ln_F_d[ptfe-c2]",
        "ln_t0[ptfe-c1-fast]",
    ] {
        assert!(ptfe.contains(&member.to_string()), "{ptfe:?}");
    }
    assert!(!ptfe.iter().any(|n| n.contains("pp-")), "{ptfe:?}");
    check_block_updates("demo by material", &post);

    let post = demo_variant(dir.path(), "demo-contact.toml", "", "contact");
    let blocks = blocks_of(&post);
    // Per material: α and a/F_d shared by its two contacts; then each contact's F_d, k and
    // its runs' t0.
    let labelled: Vec<Vec<String>> = blocks.iter().map(|b| names(&post, b)).collect();
    assert_eq!(blocks.len(), 6, "{labelled:?}");
    let material = labelled
        .iter()
        .find(|b| b.iter().any(|n| n == "ln_alpha[PTFE]"))
        .unwrap();
    assert_eq!(material.len(), 2, "{material:?}");
    assert!(material.contains(&"ln_a_over_F_d[PTFE]".to_string()));
    let contact = labelled
        .iter()
        .find(|b| b.iter().any(|n| n == "ln_F_d[ptfe-c1]"))
        .unwrap();
    for member in [
        "ln_k[ptfe-c1]",
        "ln_t0[ptfe-c1-first]",
        "ln_t0[ptfe-c1-fast]",
    ] {
        assert!(contact.contains(&member.to_string()), "{contact:?}");
    }
    // The shared block has the contacts' coordinates as followers; each contact is given
    // the shared ones.
    let links = links_of(&post);
    let m = blocks
        .iter()
        .position(|b| names(&post, b) == *material)
        .unwrap();
    let c = blocks
        .iter()
        .position(|b| names(&post, b) == *contact)
        .unwrap();
    assert_eq!(links[c].given, blocks[m]);
    assert!(links[c].followers.is_empty());
    assert!(links[m].given.is_empty());
    let followers = names(&post, &links[m].followers);
    // F_d, k and the first (and fast) slides' t0 of both PTFE contacts.
    assert_eq!(followers.len(), 7, "{followers:?}");
    assert!(followers.contains(&"ln_t0[ptfe-c2-first]".to_string()));
    assert!(
        !followers.iter().any(|n| n.contains("pp-")),
        "{followers:?}"
    );
    check_block_updates("demo by contact", &post);
}

#[test]
fn block_updates_equal_full_evaluations_in_every_variant() {
    let dir = tempfile::tempdir().unwrap();
    let variants = [
        ("pooled.toml", "[pooling]\nt0 = true"),
        ("pooled-fd.toml", "[pooling]\nt0 = true\nF_d = true"),
        (
            "pooled-a-k.toml",
            "[levels]\na = \"contact\"\n[pooling]\na = true\nk = true",
        ),
        ("absolute.toml", "aging = \"absolute\""),
        (
            "sigma.toml",
            "[levels]\nsigma = \"contact\"\n[priors]\nsigma = { dist = \"half-normal\", sd = 0.01 }",
        ),
        ("shared-k.toml", "[levels]\nk = \"material\"\nsigma = \"material\""),
    ];
    for (name, extra) in variants {
        for blocks in ["material", "contact"] {
            let post = demo_variant(dir.path(), name, extra, blocks);
            assert!(blocks_of(&post).len() >= 2, "{name}");
            // Pooling adds each material's populations as a conditional block.
            let populations = if name.starts_with("pooled") { 2 } else { 0 };
            assert_eq!(exact_of(&post).len(), populations, "{name} by {blocks}");
            check_block_updates(&format!("{name} by {blocks}"), &post);
            // By contact, a material's shared parameters split over its contacts (unless a σ
            // shared by the contacts ties them: then no block is independent).
            if blocks == "contact" {
                let splits = (0..blocks_of(&post).len()).any(|b| splits(&post, b));
                let tied = independent_of(&post).is_empty();
                assert_eq!(splits, !tied, "{name} by {blocks}");
                // And then each rank of an MPI job can hold only its contacts' data.
                assert_eq!(post.data_share().is_some(), !tied, "{name} by {blocks}");
            }
        }
    }
}

/// Which blocks are independent of one another: every contact's own block (each material's
/// block when blocked by material); none of the contacts of a material whose σ they share.
#[test]
fn contacts_are_independent_unless_a_sigma_ties_them() {
    let dir = tempfile::tempdir().unwrap();
    for (name, extra, blocks, expected) in [
        (
            "demo.toml",
            "",
            "contact",
            vec!["ptfe-c1", "ptfe-c2", "pp-c1", "pp-c2"],
        ),
        ("demo.toml", "", "material", vec!["PTFE", "PP"]),
        (
            "pooled.toml",
            "[pooling]\nt0 = true",
            "contact",
            vec!["ptfe-c1", "ptfe-c2", "pp-c1", "pp-c2"],
        ),
        (
            "shared-sigma.toml",
            "[levels]\nsigma = \"material\"",
            "contact",
            vec![],
        ),
    ] {
        let post = demo_variant(dir.path(), name, extra, blocks);
        let independent = independent_of(&post);
        let blocks = blocks_of(&post);
        let mut named: Vec<&str> = Vec::new();
        for &b in &independent {
            let names = names(&post, &blocks[b]);
            let owner = expected
                .iter()
                .find(|o| names.iter().any(|n| n.contains(&format!("[{o}"))))
                .unwrap_or_else(|| panic!("{name}: block {names:?} is not expected independent"));
            named.push(owner);
        }
        named.sort_unstable();
        let mut expected = expected.clone();
        expected.sort_unstable();
        assert_eq!(named, expected, "{name} by {blocks:?}");
    }
}

/// The friction posterior with its blocks listed in another order: within each run of
/// consecutive independent blocks, reversed.
struct Reordered<'p> {
    post: &'p Posterior,
    /// Block `k` of this density is block `order[k]` of the posterior.
    order: Vec<usize>,
}

impl<'p> Reordered<'p> {
    fn new(post: &'p Posterior) -> Self {
        let independent = independent_of(post);
        let mut order: Vec<usize> = (0..blocks_of(post).len()).collect();
        let mut start = 0;
        while start < order.len() {
            let mut end = start;
            while end < order.len() && independent.contains(&order[end]) {
                end += 1;
            }
            order[start..end].reverse();
            start = end + 1;
        }
        Self { post, order }
    }
    fn back(&self, block: usize) -> usize {
        self.order[block]
    }
}

impl LogDensity for Reordered<'_> {
    fn dim(&self) -> usize {
        self.post.dim()
    }
    fn derived_names(&self) -> Vec<String> {
        self.post.derived_names()
    }
    fn log_density(&self, x: &[f64], d: &mut [f64]) -> Result<f64, LogDensityError> {
        self.post.log_density(x, d)
    }
}

/// The posterior's plan in this order, every capability going through this density, which
/// maps the blocks back.
impl BlockedDensity for Reordered<'_> {
    fn state_len(&self) -> usize {
        self.post.state_len()
    }
    fn log_density_with_state(
        &self,
        x: &[f64],
        d: &mut [f64],
        c: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        self.post.log_density_with_state(x, d, c)
    }
    fn log_density_after_block(
        &self,
        block: usize,
        x: &[f64],
        d: &mut [f64],
        c: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        self.post.log_density_after_block(self.back(block), x, d, c)
    }
    fn block_plan(&self) -> BlockPlan<'_> {
        let mut blocks: Vec<Option<PlannedBlock>> = self
            .post
            .block_plan()
            .blocks
            .into_iter()
            .map(Some)
            .collect();
        let blocks = self
            .order
            .iter()
            .map(|&b| {
                let block = blocks[b].take().expect("each block once");
                let update = match block.update {
                    BlockUpdate::Moves { carry } => BlockUpdate::Moves {
                        carry: carry.map(|_| self as &dyn CarryFollowers),
                    },
                    BlockUpdate::Exact { carry, .. } => BlockUpdate::Exact {
                        conditional: self,
                        carry: carry.map(|c| CarriedMove {
                            map: self,
                            optional: c.optional,
                        }),
                    },
                    BlockUpdate::Independent { entries, .. } => {
                        BlockUpdate::Independent { own: self, entries }
                    }
                };
                PlannedBlock {
                    coords: block.coords,
                    links: block.links,
                    update,
                    split: block.split.map(|_| self as &dyn SplitByPart),
                }
            })
            .collect();
        BlockPlan { blocks }
    }
}

impl ExactConditional for Reordered<'_> {
    fn conditional_log_density(&self, block: usize, x: &[f64]) -> f64 {
        self.post.conditional_log_density(self.back(block), x)
    }
    fn log_density_after_draw(
        &self,
        block: usize,
        x: &[f64],
        d: &mut [f64],
        c: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        self.post.log_density_after_draw(self.back(block), x, d, c)
    }
}

impl CarryFollowers for Reordered<'_> {
    fn carry_followers(&self, block: usize, from: &[f64], to: &mut [f64]) -> f64 {
        self.post.carry_followers(self.back(block), from, to)
    }
}

impl IndependentBlocks for Reordered<'_> {
    fn block_terms(&self, block: usize, x: &[f64], state: &[f64]) -> f64 {
        self.post.block_terms(self.back(block), x, state)
    }
    fn update_block_state(
        &self,
        block: usize,
        x: &[f64],
        d: &mut [f64],
        c: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        self.post.update_block_state(self.back(block), x, d, c)
    }
    fn log_density_from_state(&self, x: &[f64], d: &mut [f64], c: &[f64]) -> f64 {
        self.post.log_density_from_state(x, d, c)
    }
}

/// The independent blocks keep their positions among the independent blocks (only runs of
/// them are reversed, and the posterior has one), so that the shares are the posterior's.
impl SplitByPart for Reordered<'_> {
    fn share_entries(&self, block: usize, parts: std::ops::Range<usize>) -> OwnEntries {
        self.post.share_entries(self.back(block), parts)
    }
    fn evaluate_share(
        &self,
        block: usize,
        parts: std::ops::Range<usize>,
        x: &[f64],
        d: &mut [f64],
        c: &mut [f64],
    ) -> Result<(), ShareError> {
        self.post.evaluate_share(self.back(block), parts, x, d, c)
    }
    fn log_density_from_shares(&self, block: usize, x: &[f64], d: &mut [f64], c: &[f64]) -> f64 {
        self.post.log_density_from_shares(self.back(block), x, d, c)
    }
}

/// The campaign's chains for 30 steps with `updates` from `init`, its contacts' blocks updated
/// in `shares` shares, all but the first on replicas, and merged (1: not split).
fn campaign_chains<D: BlockedDensity>(
    density: &D,
    updates: Updates,
    init: &[Vec<Vec<f64>>],
    shares: usize,
) -> Vec<(Vec<u64>, Vec<u64>, Vec<u64>)> {
    let config = SamplerConfig::new(16, 2, 9)
        .unwrap()
        .with_updates(updates)
        .with_moves(vec![
            (Move::student_t(), 1.0),
            (Move::differential_evolution(), 1.0),
        ])
        .unwrap();
    let mut replicas = ReplicaShares::new(Target::blocked(density), &config, shares).unwrap();
    let mut s = EnsembleSampler::new(Target::blocked(density), config, init.to_vec()).unwrap();
    if shares > 1 {
        s.set_parallelism(Parallelism::from(&mut replicas));
    }
    let mut sink = MemorySink::new();
    s.run(Steps::Fixed(30), &mut sink, &mut Silent).unwrap();
    drop(s);
    // Split, the material's shared parameters' updates split over the contacts too.
    assert_eq!(replicas.split_batches() > 0, shares > 1, "{shares} shares");
    // Bits, so that NaN derived values (no interior peak) compare equal.
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    sink.chains
        .iter()
        .map(|c| (bits(&c.positions), bits(&c.log_density), bits(&c.derived)))
        .collect()
}

/// The chains of a campaign do not depend on the order in which its contacts' blocks are
/// updated: on the demo's campaign with t0 pooled (exact population draws between the
/// contacts' updates) and with `aging = "absolute"`, under hierarchical and plain blocked
/// updates, the sampler gives the same draws, log-densities and derived values bit for bit
/// with the contacts listed in reverse, and with the contacts' blocks updated in 2 or 3 shares
/// on replicas of the sampler and merged, as the ranks of an MPI job update them.
#[test]
fn campaign_chains_do_not_depend_on_the_contacts_order() {
    let dir = tempfile::tempdir().unwrap();
    for (name, extra, updates) in [
        ("pooled.toml", "[pooling]\nt0 = true", Updates::Hierarchical),
        ("absolute.toml", "aging = \"absolute\"", Updates::Blocked),
    ] {
        let post = demo_variant(dir.path(), name, extra, "contact");
        let reordered = Reordered::new(&post);
        assert_ne!(
            reordered.order,
            (0..reordered.order.len()).collect::<Vec<_>>()
        );
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let init: Vec<Vec<Vec<f64>>> = (0..2)
            .map(|_| {
                (0..16)
                    .map(|_| {
                        post.start()
                            .iter()
                            .map(|v| v + 1e-3 * (rng.random::<f64>() - 0.5))
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let listed = campaign_chains(&post, updates, &init, 1);
        assert_eq!(
            campaign_chains(&reordered, updates, &init, 1),
            listed,
            "{name}"
        );
        for shares in [2, 3] {
            assert_eq!(
                campaign_chains(&post, updates, &init, shares),
                listed,
                "{name}: {shares} shares"
            );
        }
    }
}

/// Where the density is not finite, it says which coordinate leaves its prior and which run
/// of which contact cannot be evaluated; at the start it says nothing.
#[test]
fn the_posterior_names_what_fails_at_a_point() {
    let tmp = tempfile::tempdir().unwrap();
    let post = demo_variant(tmp.path(), "demo.toml", "", "material");
    let names = post.param_names();
    let start = post.start().to_vec();
    assert_eq!(post.explain(&start), None);

    // t0 of PTFE contact 1 far below its prior's support.
    let t0 = names
        .iter()
        .position(|n| n.contains("t0[ptfe-c1-first]"))
        .unwrap();
    let mut x = start.clone();
    x[t0] = -80.0;
    let why = post.explain(&x).expect("a reason");
    assert!(
        why.contains(&names[t0]) && why.contains("outside its prior"),
        "{why}"
    );

    // A machine soft enough (1,000 N/m, inside the prior) that PTFE contact 1's first slide
    // drops faster after its peak than the spring can follow (stick-slip): the run is named
    // with its contact.
    let k = names.iter().position(|n| n.contains("k[ptfe-c1]")).unwrap();
    let mut x = start;
    x[k] = 1000f64.ln();
    let why = post.explain(&x).expect("a reason");
    assert!(
        why.contains("run ptfe-c1-first of contact ptfe-c1"),
        "{why}"
    );
    let mut derived = vec![0.0; post.derived_names().len()];
    assert!(post.log_density(&x, &mut derived).is_err());
}

/// A prior that excludes what the data say is named, with the value the data give and what to
/// change: k's prior ends at 20 N/m while the repeat slide's loading slope says about
/// 1.2e4 N/m (the start then takes 19.8 N/m, inside the prior).
#[test]
fn a_prior_that_excludes_what_the_data_say_is_named_with_their_value() {
    let tmp = tempfile::tempdir().unwrap();
    let model = tmp.path().join("k.toml");
    let data = |file: &str| root().join("data").join(file).display().to_string();
    std::fs::write(
        &model,
        format!(
            "[[material]]\nname = \"PTFE\"\n[[contact]]\nname = \"c1\"\nmaterial = \"PTFE\"\n\
             [[run]]\nname = \"c1-first\"\ncontact = \"c1\"\ndata = \"{}\"\n\
             velocity_m_per_s = 1e-9\nscene = \"first\"\n\
             [[run]]\nname = \"c1-repeat\"\ncontact = \"c1\"\ndata = \"{}\"\n\
             velocity_m_per_s = 1e-9\nscene = \"repeat\"\n\
             [priors]\nk = {{ dist = \"log-uniform\", low = 10, high = 20 }}\n",
            data("ptfe-c1-first.csv"),
            data("ptfe-c1-repeat.csv")
        ),
    )
    .unwrap();
    let post = RunFile::load(&model).unwrap().posterior().unwrap();
    let start = post.start().to_vec();
    let why = post.explain(&start).expect("a reason");
    for part in [
        "the data say k[c1] (contact c1) is about 1.",
        "e4 N/m, which its prior, log-uniform on [1e1, 2e1] N/m, excludes",
        &format!(
            "in {}, change the prior of `k` under `[priors]`",
            model.display()
        ),
    ] {
        assert!(why.contains(part), "`{part}` not in `{why}`");
    }
}
