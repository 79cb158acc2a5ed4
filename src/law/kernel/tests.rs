use super::newton::{newton_step, third_order_step, Start};
use super::*;
use crate::law::observed::solve_point;
use crate::law::LawParams;
use crate::special::lanes::X_LANES_MAX;

/// The times' check gives the same verdict on every instruction set wherever the pair out
/// of order lies (in the vector body or the scalar tail of 37 times): equal, NaN, or a
/// first time of −∞.
#[test]
fn times_out_of_order_are_found_on_every_instruction_set() {
    let sorted: Vec<f64> = (0..37).map(|i| 0.5 * i as f64).collect();
    for simd in Simd::available() {
        assert!(strictly_increasing(simd, &sorted), "{simd:?}");
        assert!(strictly_increasing(simd, &[]), "{simd:?}");
        assert!(
            !strictly_increasing(simd, &[f64::NEG_INFINITY, 0.0]),
            "{simd:?}"
        );
        for i in 1..sorted.len() {
            for odd in [sorted[i - 1], f64::NAN] {
                let mut times = sorted.clone();
                times[i] = odd;
                assert!(!strictly_increasing(simd, &times), "{simd:?}: {odd} at {i}");
            }
        }
    }
}

/// The step of third order from a guess whose Newton step is far from final lands on the
/// root to a few ulps, in τ and in F, and says so; on the steep rise of a slow slide (x = 2)
/// and beyond it. Its predicted error must also be honest: a guess so far off that the step
/// cannot be final is not declared final.
#[test]
fn the_third_order_step_is_final_where_the_newton_step_is_not() {
    let law = Law::new(&LawParams::new(0.92e6, 6.2e-3, 10e-3, 14.8).unwrap(), 1e-9).unwrap();
    let kv = 1.2e4 * 1e-9;
    for x in [0.8, 2.0, 7.0, 30.0] {
        let tau = x / law.alpha_v;
        let t = tau + law.force_and_rate(tau).0 / kv;
        let lo = law.t0();
        let (root, root_force, _) = solve_point(&law, kv, lo, t, tau).unwrap();
        // (How far the guess is off, relatively; whether the step is final from it; whether
        // Newton's is off by more than 1e-13 there, which holds on the steep rise.)
        for (offset, final_expected, newton_far) in [
            (1e-7, true, false),
            (1e-6, true, false),
            (3e-6, true, x <= 7.0),
            (1e-2, false, true),
        ] {
            let guess = root * (1.0 + offset);
            let (force, rate) = law.force_and_rate(guess);
            let inv_x = 1.0 / (law.alpha_v * guess);
            let at = Start {
                t,
                tau: guess,
                force,
                rate,
                inv_x,
            };
            let newton = newton_step(&law, 1.0 / kv, lo, at);
            let third = third_order_step(&law, 1.0 / kv, lo, at);
            let what = format!("x {x}, guess off by {offset:e}: {newton:?} {third:?}");
            assert!(!newton.converged, "{what}");
            assert_eq!(third.converged, final_expected, "{what}");
            if final_expected {
                assert!(
                    (third.tau - root).abs() <= 2.0 * f64::EPSILON * root,
                    "{what}"
                );
                assert!(
                    (third.force - root_force).abs() <= 8.0 * f64::EPSILON * root_force.abs(),
                    "{what}: F {root_force:e}"
                );
            }
            if newton_far {
                assert!((newton.tau - root).abs() > 1e-13 * root, "{what}");
            }
        }
    }
}

/// A batch in the lanes' regimes stays in lanes; one lane that is NaN, past the lanes'
/// range or negative sends the whole batch to the scalar law, whose values it then has
/// bit for bit (the range check is a reduction over the batch, and a NaN lane must not
/// slip through its smallest and largest x).
#[test]
fn a_lane_out_of_range_sends_the_batch_to_the_scalar_law() {
    let law = Law::new(&LawParams::new(0.92e6, 6.2e-3, 10e-3, 14.8).unwrap(), 1e-9).unwrap();
    let lanes = LawLanes::new(&law);
    // x = αvτ from 2 to about 30: the subtraction regime.
    let clean: Lanes = std::array::from_fn(|l| (2.0 + l as f64) / law.alpha_v);
    let beyond = 2.0 * X_LANES_MAX / law.alpha_v;
    for (name, odd) in [
        ("none", None),
        ("NaN", Some(f64::NAN)),
        ("beyond", Some(beyond)),
        ("negative", Some(-1.0)),
    ] {
        for lane in [0, 13, LANES - 1] {
            let mut tau = clean;
            if let Some(v) = odd {
                tau[lane] = v;
            }
            let (mut force, mut rate, mut inv_x) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
            let mut counts = KernelCounts::default();
            lanes.force_and_rate(&tau, &mut force, &mut rate, &mut inv_x, &mut counts);
            let expected_scalar = u64::from(odd.is_some());
            assert_eq!(
                counts.scalar_law_batches, expected_scalar,
                "{name} at lane {lane}"
            );
            if odd.is_some() {
                for l in 0..LANES {
                    let (f, r) = law.force_and_rate(tau[l]);
                    assert_eq!(
                        (force[l].to_bits(), rate[l].to_bits()),
                        (f.to_bits(), r.to_bits()),
                        "{name} at lane {lane}: lane {l}"
                    );
                }
            }
        }
    }
}
