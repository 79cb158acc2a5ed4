"""Reference forces for slipbayes' rate-and-state spring-slider (tests/rate_state.rs).

The model (src/law/rate_state.rs): a spring of stiffness k pulled at load-point velocity v
drives a slider whose friction force is

    F = F0 + a ln(V/V0) + b ln(V0 theta/D_c)

with the state theta evolving by the Dieterich aging law, d theta/dt = 1 - V theta/D_c, or the
Ruina slip law, d theta/dt = -(V theta/D_c) ln(V theta/D_c), and the quasi-static spring
dF/dt = k (v - V). V is the friction law solved for the slip velocity.

This script integrates that system independently of the Rust code: in SI units, in the
variables (F, ln theta) rather than the dimensionless ones the library uses, with scipy's
Radau (solve_ivp) at rtol = 1e-13 and an absolute tolerance of 1e-15 a on F and 1e-15 on
ln theta, with the analytic Jacobian. Each observation time is an end point of its own
integration (the run restarts from the previous time's state), so no value comes from dense
output. The same run at rtol = 1e-12 is compared with it; the largest relative difference,
`reference_self_difference`, bounds the reference's own error and is written with the data.

Cases: a slow first slide after a long hold (a clear peak), the same with a stiff machine
(k D_c / a = 1e6), and a velocity step from steady sliding (V0 = the first velocity), each
for both state laws.

Run with a Python that has scipy:
    python3 -m venv /tmp/rs && /tmp/rs/bin/pip install scipy==1.17.1
    /tmp/rs/bin/python tests/reference/rate_state/make_reference.py
"""

import json
import math
import pathlib

import numpy as np
import scipy
from scipy.integrate import solve_ivp

RTOL = 1e-13
RTOL_CHECK = 1e-12


def rhs_and_jacobian(case):
    a, b, dc = case["a_n"], case["b_n"], case["dc_m"]
    f0, k, v, v0 = case["f0_n"], case["k_n_per_m"], case["v_m_per_s"], case["v_ref_m_per_s"]
    slip_law = case["state_law"] == "slip"

    def velocity(y):
        force, ln_theta = y
        return v0 * math.exp((force - f0 - b * (math.log(v0 / dc) + ln_theta)) / a)

    def rhs(_t, y):
        vel = velocity(y)
        ln_omega = math.log(vel / dc) + y[1]
        if slip_law:
            dln_theta = -(vel / dc) * ln_omega
        else:
            dln_theta = math.exp(-y[1]) - vel / dc
        return [k * (v - vel), dln_theta]

    def jac(_t, y):
        vel = velocity(y)
        dvel_dforce = vel / a
        dvel_dln_theta = -b * vel / a
        ln_omega = math.log(vel / dc) + y[1]
        if slip_law:
            # d/dx of -(V/Dc) ln(V theta/Dc), with d ln(omega) = dV/V + d ln theta.
            row = [
                -(dvel_dforce / dc) * ln_omega - (vel / dc) * (dvel_dforce / vel),
                -(dvel_dln_theta / dc) * ln_omega - (vel / dc) * (dvel_dln_theta / vel + 1.0),
            ]
        else:
            row = [-dvel_dforce / dc, -math.exp(-y[1]) - dvel_dln_theta / dc]
        return [[-k * dvel_dforce, -k * dvel_dln_theta], row]

    return rhs, jac, velocity


def initial_state(case):
    init = case["initial"]
    if init["kind"] == "hold":
        return [0.0, math.log(init["hold_s"])]
    # Steady sliding at an earlier velocity: theta = D_c/v1, F = F0 + (a - b) ln(v1/V0).
    v1 = init["velocity_m_per_s"]
    force = case["f0_n"] + (case["a_n"] - case["b_n"]) * math.log(v1 / case["v_ref_m_per_s"])
    return [force, math.log(case["dc_m"] / v1)]


def integrate(case, rtol):
    rhs, jac, velocity = rhs_and_jacobian(case)
    atol = [1e-15 * case["a_n"], 1e-15]
    y = initial_state(case)
    t_prev = 0.0
    out = []
    for t in case["times_s"]:
        if t > t_prev:
            sol = solve_ivp(rhs, (t_prev, t), y, method="Radau", jac=jac, rtol=rtol, atol=atol)
            if not sol.success:
                raise RuntimeError(f"{case['name']}: {sol.message} at t = {t}")
            y = [sol.y[0, -1], sol.y[1, -1]]
            t_prev = t
        out.append((y[0], math.exp(y[1]), velocity(y)))
    return out


def case(name, state_law, times, initial, **params):
    c = {"name": name, "state_law": state_law, "initial": initial}
    c.update(params)
    c["times_s"] = [float(t) for t in times]
    return c


def times_for(end_s, early_s, n_lin=40, n_log=20):
    lin = np.linspace(0.0, end_s, n_lin + 1)
    log = np.geomspace(early_s, end_s, n_log)
    return np.unique(np.concatenate([lin, log]))


CASES = []
for law in ("aging", "slip"):
    # Slow first slide after a 10^4 s hold: theta0 = 100 theta_ss, a clear peak; slip 30 D_c.
    CASES.append(
        case(
            f"slow_first_{law}",
            law,
            times_for(3000.0, 1.0),
            {"kind": "hold", "hold_s": 1e4},
            a_n=1e-3, b_n=1.5e-3, dc_m=1e-6, f0_n=10e-3,
            k_n_per_m=1.2e4, v_m_per_s=1e-8, v_ref_m_per_s=1e-8,
        )
    )
    # A stiff machine, k D_c / a = 1e6 (the spring loads in microseconds), rate-strengthening.
    CASES.append(
        case(
            f"stiff_{law}",
            law,
            times_for(30.0, 1e-6),
            {"kind": "hold", "hold_s": 10.0},
            a_n=1e-3, b_n=0.8e-3, dc_m=1e-6, f0_n=10e-3,
            k_n_per_m=1e9, v_m_per_s=1e-6, v_ref_m_per_s=1e-6,
        )
    )
    # A tenfold velocity step from steady sliding at V0 = 1 um/s.
    CASES.append(
        case(
            f"step_{law}",
            law,
            times_for(3.0, 1e-4),
            {"kind": "steady", "velocity_m_per_s": 1e-6},
            a_n=1e-3, b_n=1.2e-3, dc_m=1e-6, f0_n=10e-3,
            k_n_per_m=1e5, v_m_per_s=1e-5, v_ref_m_per_s=1e-6,
        )
    )


def main():
    for c in CASES:
        fine = integrate(c, RTOL)
        coarse = integrate(c, RTOL_CHECK)
        c["force_n"] = [f for f, _, _ in fine]
        c["theta_s"] = [th for _, th, _ in fine]
        c["velocity_m_per_s"] = [vel for _, _, vel in fine]
        # Relative to the force scale max(|F|, a), as tests/rate_state.rs compares.
        c["reference_self_difference"] = max(
            abs(f1 - f2) / max(abs(f1), c["a_n"]) for (f1, _, _), (f2, _, _) in zip(fine, coarse)
        )
        print(f"{c['name']}: {len(c['times_s'])} points, peak {max(c['force_n']):.6e} N, "
              f"self difference {c['reference_self_difference']:.2e}")
    out = {
        "generator": "tests/reference/rate_state/make_reference.py",
        "scipy": scipy.__version__,
        "rtol": RTOL,
        "cases": CASES,
    }
    path = pathlib.Path(__file__).with_name("reference.json")
    path.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
