//! The blocks a step updates in turn, checked against the density and the configuration, and
//! the per-block state the ensembles keep for them.

use super::super::config::{SamplerConfig, Updates};
use super::super::ensemble::UpdateBlock;
use super::super::error::SamplerError;
use super::super::moves::CarryTuning;
use crate::density::LogDensity;

/// The blocks a step updates in turn: the density's, validated, when the configuration asks
/// for blocked updates and the density has two or more, with their links when it asks for
/// hierarchical ones; none (joint updates) otherwise.
pub(super) fn blocks_of<D: LogDensity + ?Sized>(
    density: &D,
    config: &SamplerConfig,
) -> Result<Vec<UpdateBlock>, SamplerError> {
    let blocks = match config.updates() {
        Updates::Joint => return Ok(Vec::new()),
        Updates::Blocked | Updates::Hierarchical => density.blocks(),
    };
    // One block (or none) is the whole space: joint updates.
    if blocks.len() <= 1 {
        return Ok(Vec::new());
    }
    let ndim = density.dim();
    let mut seen = vec![false; ndim];
    let disjoint = blocks
        .iter()
        .flatten()
        .all(|&i| i < ndim && !std::mem::replace(&mut seen[i], true));
    if !disjoint || blocks.iter().any(Vec::is_empty) || seen.contains(&false) {
        return Err(SamplerError::InvalidConfig {
            name: "blocks",
            value: format!("{blocks:?}"),
            requirement: format!(
                "the density's blocks must be non-empty, disjoint and cover all {ndim} coordinates"
            ),
        });
    }
    let hierarchical = config.updates() == Updates::Hierarchical;
    let links = if hierarchical {
        density.block_links()
    } else {
        Vec::new()
    };
    if !links.is_empty() {
        let in_range = links
            .iter()
            .flat_map(|l| l.given.iter().chain(&l.followers))
            .all(|&i| i < ndim);
        let outside = links
            .iter()
            .zip(&blocks)
            .all(|(l, b)| !l.given.iter().chain(&l.followers).any(|i| b.contains(i)));
        if links.len() != blocks.len() || !in_range || !outside {
            return Err(SamplerError::InvalidConfig {
                name: "block_links",
                value: format!("{links:?}"),
                requirement: format!(
                    "one entry per block ({}), each naming coordinates below {ndim} outside its block",
                    blocks.len()
                ),
            });
        }
    }
    let conditional = density.conditional_blocks();
    if let Some(&b) = conditional.iter().find(|&&b| b >= blocks.len()) {
        return Err(SamplerError::InvalidConfig {
            name: "conditional_blocks",
            value: format!("{conditional:?}"),
            requirement: format!(
                "block {b} does not exist: name blocks below {}",
                blocks.len()
            ),
        });
    }
    let independent = density.independent_blocks();
    if let Some(&b) = independent.iter().find(|&&b| {
        b >= blocks.len()
            || conditional.contains(&b)
            || (hierarchical && density.carries_followers(b))
            || links.get(b).is_some_and(|l| !l.followers.is_empty())
    }) {
        return Err(SamplerError::InvalidConfig {
            name: "independent_blocks",
            value: format!("{independent:?}"),
            requirement: format!(
                "block {b} cannot be updated independently: name existing blocks (below {}) \
                 that are not drawn exactly and have no followers",
                blocks.len()
            ),
        });
    }
    let mut links = links.into_iter();
    Ok(blocks
        .into_iter()
        .enumerate()
        .map(|(b, coords)| UpdateBlock {
            coords,
            links: links.next().unwrap_or_default(),
            conditional: conditional.contains(&b),
            density_carries: hierarchical && density.carries_followers(b),
            carry_measured: hierarchical
                && conditional.contains(&b)
                && density.carries_followers(b)
                && density.carried_move_optional(b),
            tuned_carry: false,
            independent: independent.contains(&b),
        })
        .map(|mut b| {
            b.tuned_carry = hierarchical
                && !b.density_carries
                && config
                    .carry()
                    .tunes(b.links.followers.len(), config.walkers());
            b
        })
        .collect())
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
