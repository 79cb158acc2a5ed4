//! The search by blocks against the dense search and the dense finite differences.

use nalgebra::DVector;

use super::*;
use crate::density::{LogDensity, Target};
use crate::optimize::laplace::find_mode;
use crate::optimize::probe::Probe;
use crate::run_file::RunFile;

/// The demo's posterior: two materials' shared parameters and four contacts, each an
/// independent block.
fn demo() -> crate::model::Posterior {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    RunFile::load(&root.join("models/demo.toml"))
        .unwrap()
        .posterior()
        .unwrap()
}

/// `−∇² ln p` at `x` from the dense central differences (every pair of coordinates).
fn dense_curvature(posterior: &crate::model::Posterior, x: &[f64]) -> DMatrix<f64> {
    let n = x.len();
    let h = hessian_steps(x);
    let d = Probe::new(Target::blocked(posterior)).second_differences(x, &h);
    let mut k = DMatrix::zeros(n, n);
    for i in 0..n {
        let [fp, fm] = d.axis[i];
        k[(i, i)] = -(fp - 2.0 * d.at_x + fm) / (h[i] * h[i]);
        for j in 0..i {
            let [pp, pm, mp, mm] = d.pairs[i][j];
            k[(i, j)] = -(pp - pm - mp + mm) / (4.0 * h[i] * h[j]);
            k[(j, i)] = k[(i, j)];
        }
    }
    k
}

/// The arrowhead curvature of `local` as a dense matrix.
fn assembled(by: &ByBlocks<'_>, local: &Local, n: usize) -> DMatrix<f64> {
    let mut k = DMatrix::zeros(n, n);
    for (a, &i) in by.shared.iter().enumerate() {
        for (c, &j) in by.shared.iter().enumerate() {
            k[(i, j)] = local.shared[(a, c)];
        }
    }
    for (b, c) in by.blocks.iter().zip(&local.blocks) {
        for (a, &i) in b.coords.iter().enumerate() {
            for (e, &j) in b.coords.iter().enumerate() {
                k[(i, j)] = c.own[(a, e)];
            }
            for (e, &j) in by.shared.iter().enumerate() {
                k[(i, j)] = c.cross[(a, e)];
                k[(j, i)] = c.cross[(a, e)];
            }
        }
    }
    k
}

/// Every entry of the curvature by blocks is the dense finite differences' (those between
/// two blocks are zero there too), to the rounding of differences of the whole
/// log-density, on the scale `√(K_ii K_jj)` of each entry.
#[test]
fn the_curvature_by_blocks_is_the_dense_one() {
    let posterior = demo();
    let by = ByBlocks::new(&posterior).expect("the demo has independent contacts");
    assert!(by.blocks.len() >= 4 && !by.shared.is_empty());
    let x = posterior.start().to_vec();
    let n = x.len();
    let local = by.local(&x).unwrap();
    assert!(local.finite);
    let ours = assembled(&by, &local, n);
    let dense = dense_curvature(&posterior, &x);
    let h = gradient_steps(&x);
    for i in 0..n {
        for j in 0..n {
            let scale = (dense[(i, i)].abs() * dense[(j, j)].abs()).sqrt();
            let diff = (ours[(i, j)] - dense[(i, j)]).abs();
            assert!(
                diff <= 1e-6 * scale,
                "K[{i}, {j}]: {} by blocks, {} dense",
                ours[(i, j)],
                dense[(i, j)]
            );
        }
        // The gradient: central differences of the whole log-density.
        let mut y = x.clone();
        y[i] = x[i] + h[i];
        let fp = posterior
            .log_density(&y, &mut vec![0.0; posterior.derived_names().len()])
            .unwrap();
        y[i] = x[i] - h[i];
        let fm = posterior
            .log_density(&y, &mut vec![0.0; posterior.derived_names().len()])
            .unwrap();
        let g = (fp - fm) / (2.0 * h[i]);
        assert!(
            (local.gradient[i] - g).abs() <= 1e-6 * dense[(i, i)].abs().sqrt() * (1.0 + g.abs()),
            "gradient {i}: {} and {g}",
            local.gradient[i]
        );
    }
}

/// The factor solves with the curvature it factors, and its draws have its inverse as
/// their covariance: `Σ_i draw(e_i) draw(e_i)ᵀ = K⁻¹`.
#[test]
fn the_factor_inverts_the_curvature_and_draws_from_its_inverse() {
    let posterior = demo();
    let by = ByBlocks::new(&posterior).unwrap();
    let x = posterior.start().to_vec();
    let n = x.len();
    let local = by.local(&x).unwrap();
    let k = assembled(&by, &local, n);
    // Damped enough to be positive definite wherever the start is.
    let scale = by.damping_scale(&local);
    let mut lambda = 1.0;
    let factor = loop {
        match by.factor(&local, Some((lambda, &scale))) {
            Some(factor) => break factor,
            None => lambda *= 10.0,
        }
    };
    let mut damped = k.clone();
    for i in 0..n {
        damped[(i, i)] += lambda * scale[i];
    }
    let cov = DMatrix::from_row_slice(n, n, &factor.to_dense(n));
    let identity = &cov * &damped;
    for i in 0..n {
        for j in 0..n {
            let want = if i == j { 1.0 } else { 0.0 };
            assert!(
                (identity[(i, j)] - want).abs() < 1e-8,
                "(Σ K)[{i}, {j}] = {}",
                identity[(i, j)]
            );
        }
    }
    let mut outer = DMatrix::zeros(n, n);
    for i in 0..n {
        let mut e = DVector::zeros(n);
        e[i] = 1.0;
        let d = factor.draw(&e);
        outer += &d * d.transpose();
    }
    for i in 0..n {
        for j in 0..n {
            let scale = (cov[(i, i)] * cov[(j, j)]).sqrt();
            assert!(
                (outer[(i, j)] - cov[(i, j)]).abs() < 1e-10 * scale,
                "draws' covariance [{i}, {j}]"
            );
        }
    }
}

/// A campaign of `contacts` contacts of one material (a first slide and a repeat slide
/// each, simulated with contact-to-contact spread in F_d, k and t0), as
/// `data/make_campaign.py` makes them.
fn campaign(contacts: usize) -> crate::model::Posterior {
    use crate::law::{LawParams, Scene};
    use crate::simulate::{simulate, SimulationSpec};
    let dir = tempfile::tempdir().unwrap();
    let mut model = String::from("[[material]]\nname = \"M\"\n");
    let mut runs = String::new();
    let mut series = Vec::new();
    for c in 1..=contacts {
        let spread = |sd: f64, z: f64| (sd * z).exp();
        let z = |k: usize| ((c * 7 + k * 3) % 11) as f64 / 5.0 - 1.0;
        let f_d = 10e-3 * spread(0.15, z(0));
        let (k, t0) = (1.2e4 * spread(0.2, z(1)), 15.0 * spread(0.5, z(2)));
        let params = LawParams::new(0.92e6, 0.62 * f_d, f_d, t0).unwrap();
        model += &format!("\n[[contact]]\nname = \"c{c}\"\nmaterial = \"M\"\n");
        for (scene, label, duration_s, interval_s, after_first_s) in [
            (Scene::First, "first", 20_000.0, 100.0, None),
            (Scene::Repeat, "repeat", 2_000.0, 40.0, Some(20_000.0)),
        ] {
            runs += &format!(
                "\n[[run]]\nname = \"c{c}-{label}\"\ncontact = \"c{c}\"\ndata = \"c{c}-{label}.csv\"\n\
                 velocity_m_per_s = 1e-9\nscene = \"{label}\"\n"
            );
            let spec = SimulationSpec {
                scene,
                params,
                stiffness_n_per_m: Some(k),
                law: Default::default(),
                rigid: false,
                velocity_m_per_s: 1e-9,
                duration_s,
                interval_s,
                noise_sd_n: 1e-4,
                seed: 10 * c as u64 + u64::from(scene == Scene::Repeat),
                f_end_n: None,
                after_first_s,
                normal_force_n: None,
                normal_noise_sd_n: 0.0,
            };
            series.push(simulate(&spec).unwrap().series);
        }
    }
    let path = dir.path().join("campaign.toml");
    std::fs::write(&path, model + &runs).unwrap();
    let run_file = RunFile::load(&path).unwrap();
    let data = series
        .into_iter()
        .enumerate()
        .map(|(i, s)| crate::model::data::RunData::for_series(&run_file.model, i, s).unwrap())
        .collect();
    crate::model::Posterior::from_data(&run_file.model, run_file.blocking(), data).unwrap()
}

/// On a campaign of six contacts, from the rough start, the search by blocks ends at the
/// dense search's mode, within a hundredth of a posterior standard deviation in every
/// coordinate, with the same covariance to a few parts in a thousand.
#[test]
fn the_mode_by_blocks_is_the_dense_mode() {
    let posterior = campaign(6);
    let by = ByBlocks::new(&posterior).unwrap();
    let start = posterior.start().to_vec();
    let n = start.len();
    let ours = by.find_mode(&start).unwrap();
    let dense = find_mode(Target::joint(&posterior), &start).unwrap();
    assert!(ours.positive_definite && dense.positive_definite);
    let (c_ours, c_dense) = (ours.covariance.to_dense(n), dense.covariance.to_dense(n));
    assert!(
        ours.log_density >= dense.log_density - 1e-6,
        "{} < {}",
        ours.log_density,
        dense.log_density
    );
    for i in 0..n {
        let sd = c_dense[i * n + i].sqrt();
        assert!(
            (ours.x[i] - dense.x[i]).abs() < 1e-2 * sd,
            "coordinate {i}: {} and {} (sd {sd})",
            ours.x[i],
            dense.x[i]
        );
        for j in 0..n {
            let scale = (c_dense[i * n + i] * c_dense[j * n + j]).sqrt();
            assert!(
                (c_ours[i * n + j] - c_dense[i * n + j]).abs() < 5e-3 * scale,
                "covariance [{i}, {j}]: {} and {}",
                c_ours[i * n + j],
                c_dense[i * n + j]
            );
        }
    }
    println!(
        "evaluations: by blocks {} (of a block's terms or in full), dense {}",
        ours.evaluations, dense.evaluations
    );
}

/// On the demo, whose fast PTFE slide puts the dense search's mode on a kink of the
/// log-density (a gradient of 2·10⁴ along that slide's t0 there), the search by blocks
/// ends at the smooth mode beside it, within half a unit of log-density.
#[test]
fn on_the_demo_the_mode_by_blocks_is_within_half_a_unit_of_the_dense_one() {
    let posterior = demo();
    let start = posterior.start().to_vec();
    let ours = ByBlocks::new(&posterior)
        .unwrap()
        .find_mode(&start)
        .unwrap();
    let dense = find_mode(Target::joint(&posterior), &start).unwrap();
    assert!(ours.positive_definite);
    assert!(
        (ours.log_density - dense.log_density).abs() < 0.5,
        "{} and {}",
        ours.log_density,
        dense.log_density
    );
}
