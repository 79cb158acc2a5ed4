//! The blocks a step updates in turn, checked against the density and the configuration, and
//! the per-block state the ensembles keep for them.

use super::super::config::{SamplerConfig, Updates};
use super::super::ensemble::{BlockKind, UpdateBlock};
use super::super::error::SamplerError;
use super::super::moves::CarryTuning;
use crate::density::{
    BlockLinks, BlockPlan, BlockUpdate, BlockedDensity, LogDensity, PlannedBlock, Target,
};

/// The blocks a step updates in turn: the density's plan, validated, when the target offers
/// blocks, the configuration asks for blocked updates and the plan has two or more, with
/// their links and the density's carried moves when it asks for hierarchical ones; none
/// (joint updates) otherwise.
pub(super) fn blocks_of<'a, D: LogDensity + ?Sized>(
    target: Target<'a, D>,
    config: &SamplerConfig,
) -> Result<Vec<UpdateBlock<'a>>, SamplerError> {
    let Some(blocked) = target.blocked_density() else {
        return Ok(Vec::new());
    };
    if config.updates() == Updates::Joint {
        return Ok(Vec::new());
    }
    let plan = blocked.block_plan();
    // One block (or none) is the whole space: joint updates.
    if plan.blocks.len() <= 1 {
        return Ok(Vec::new());
    }
    let density = target.density();
    check_cover(&plan, density.dim())?;
    let hierarchical = config.updates() == Updates::Hierarchical;
    if hierarchical {
        check_links(&plan, density.dim())?;
    }
    let sizes = (density.derived_names().len(), blocked.state_len());
    check_independent(&plan, hierarchical, sizes)?;
    Ok(plan
        .blocks
        .into_iter()
        .map(|block| update_block(blocked, block, hierarchical, config))
        .collect())
}

/// The sampler's view of a block of the plan under `config` (`hierarchical`: its updates).
fn update_block<'a>(
    density: &'a dyn BlockedDensity,
    block: PlannedBlock<'a>,
    hierarchical: bool,
    config: &SamplerConfig,
) -> UpdateBlock<'a> {
    let PlannedBlock {
        coords,
        links,
        update,
        split,
    } = block;
    // Links and the density's carried moves are what hierarchical updates add.
    let links = if hierarchical {
        links
    } else {
        BlockLinks::default()
    };
    let (kind, carry_measured) = match update {
        BlockUpdate::Moves { carry } => (
            BlockKind::Moves {
                carry: carry.filter(|_| hierarchical),
            },
            false,
        ),
        BlockUpdate::Exact { conditional, carry } => {
            let carry = carry.filter(|_| hierarchical);
            (
                BlockKind::Exact {
                    conditional,
                    carry: carry.map(|c| c.map),
                },
                carry.is_some_and(|c| c.optional),
            )
        }
        BlockUpdate::Independent { own, entries } => {
            (BlockKind::Independent { own, entries }, false)
        }
    };
    let mut block = UpdateBlock {
        density,
        coords,
        links,
        kind,
        carry_measured,
        tuned_carry: false,
        split,
    };
    block.tuned_carry = hierarchical
        && block.carry().is_none()
        && config
            .carry()
            .tunes(block.links.followers.len(), config.walkers());
    block
}

/// The plan's blocks must be non-empty, disjoint and cover all `ndim` coordinates.
fn check_cover(plan: &BlockPlan, ndim: usize) -> Result<(), SamplerError> {
    let mut seen = vec![false; ndim];
    let disjoint = plan
        .blocks
        .iter()
        .flat_map(|b| &b.coords)
        .all(|&i| i < ndim && !std::mem::replace(&mut seen[i], true));
    if !disjoint || plan.blocks.iter().any(|b| b.coords.is_empty()) || seen.contains(&false) {
        return Err(SamplerError::InvalidConfig {
            name: "blocks",
            value: format!("{:?}", plan.coords()),
            requirement: format!(
                "the density's blocks must be non-empty, disjoint and cover all {ndim} coordinates"
            ),
        });
    }
    Ok(())
}

/// Every block's links must name coordinates below `ndim` outside the block.
fn check_links(plan: &BlockPlan, ndim: usize) -> Result<(), SamplerError> {
    let valid = plan.blocks.iter().all(|b| {
        b.links
            .given
            .iter()
            .chain(&b.links.followers)
            .all(|i| *i < ndim && !b.coords.contains(i))
    });
    if valid {
        return Ok(());
    }
    let links: Vec<&BlockLinks> = plan.blocks.iter().map(|b| &b.links).collect();
    Err(SamplerError::InvalidConfig {
        name: "block_links",
        value: format!("{links:?}"),
        requirement: format!("each block's links name coordinates below {ndim} outside the block"),
    })
}

/// An independent block must have no followers (under hierarchical updates, which carry
/// them), nor a split update, and its entries must lie within the derived values and the
/// state (`sizes`).
fn check_independent(
    plan: &BlockPlan,
    hierarchical: bool,
    (nderived, state_len): (usize, usize),
) -> Result<(), SamplerError> {
    for (b, block) in plan.blocks.iter().enumerate() {
        let BlockUpdate::Independent { entries, .. } = &block.update else {
            continue;
        };
        let refused = (hierarchical && !block.links.followers.is_empty())
            || block.split.is_some()
            || entries.derived.iter().any(|&j| j >= nderived)
            || entries.state.iter().any(|&j| j >= state_len);
        if refused {
            return Err(SamplerError::InvalidConfig {
                name: "independent_blocks",
                value: format!("block {b} ({:?})", block.coords),
                requirement: format!(
                    "an independent block has no followers and no split update, and its \
                     entries lie below {nderived} derived values and {state_len} of state"
                ),
            });
        }
    }
    Ok(())
}

/// A fresh tuning for every block whose followers are carried by a tuned regression; none
/// when no block is.
pub(super) fn fresh_carry_fits(blocks: &[UpdateBlock]) -> Vec<Option<CarryTuning>> {
    if !blocks.iter().any(|b| b.tuned_carry) {
        return Vec::new();
    }
    blocks
        .iter()
        .map(|b| {
            b.tuned_carry
                .then(|| CarryTuning::new(b.coords.len(), b.links.followers.len()))
        })
        .collect()
}

/// Whether a stored state's tunings are those `blocks` need.
pub(super) fn carry_fits_match(fits: &[Option<CarryTuning>], blocks: &[UpdateBlock]) -> bool {
    if !blocks.iter().any(|b| b.tuned_carry) {
        return fits.is_empty();
    }
    fits.len() == blocks.len()
        && fits.iter().zip(blocks).all(|(f, b)| match f {
            Some(t) => b.tuned_carry && t.fits(b.coords.len(), b.links.followers.len()),
            None => !b.tuned_carry,
        })
}

/// Update slots with a slice scale μ of their own: one for joint updates, one per block
/// otherwise; none when the moves hold no slice move.
pub(super) fn slice_slots(config: &SamplerConfig, blocks: &[UpdateBlock]) -> usize {
    if config.moves().iter().any(|(m, _)| m.is_slice()) {
        blocks.len().max(1)
    } else {
        0
    }
}

/// The walkers must span the space each move acts in: the whole space, or each block.
pub(super) fn check_dims(
    ndim: usize,
    blocks: &[UpdateBlock],
    config: &SamplerConfig,
) -> Result<(), SamplerError> {
    let span = blocks.iter().map(|b| b.coords.len()).max().unwrap_or(ndim);
    if ndim == 0 {
        return Err(SamplerError::InvalidConfig {
            name: "dim",
            value: "0".into(),
            requirement: "the density must have at least one parameter".into(),
        });
    }
    if config.walkers() < 2 * span {
        let what = if blocks.is_empty() {
            "ndim"
        } else {
            "the largest block"
        };
        return Err(SamplerError::InvalidConfig {
            name: "walkers",
            value: config.walkers().to_string(),
            requirement: format!(
                "must be at least 2 × {what} = {} for this density",
                2 * span
            ),
        });
    }
    for (m, _) in config.moves() {
        m.validate_complement(config.walkers() / 2, span)?;
    }
    Ok(())
}
