"""Forward-model speed: the closed-form pendulum against solve_ivp doing the same work.

Run ``python benchmarks/forward.py``. One "sequence" is a drop's fall plus 40 flights; the
closed form is timed vectorised over 64 parameter sets (one ``bounce_sequence`` call, so the
geometry and validity checks are included), best of several ``timeit`` repeats. The ODE
reference integrates θ̈ = γ cos θ with ``solve_ivp`` (DOP853, rtol 1e-12) and terminal events,
as ``tests/unit/physics/test_pendulum.py`` does: the fall to θ = θ_C, then each flight from θ_C
at the exact launch speed, up to its turning point and down to θ_C (two calls, so that the contact
event cannot fire at the start). A cheaper ODE baseline (the climb only, doubled) is timed too.
The ODE is timed on a subset of the 64 sets and scaled, as the output says. Both results are
compared, so the speed-up is for the same answer.

Goals (the issue): ≤ 10 µs per sequence, ≥ 1000× faster than the ODE.
"""

from __future__ import annotations

import argparse
import os
import time
import timeit

import numpy as np
from scipy.integrate import solve_ivp

from drumroll.physics import StickGeometry, bounce_sequence, prepare_release

STICK = StickGeometry("cylinder-cone", length=0.348, tip=0.060, radius=0.0075)
N_SETS, N_FLIGHTS = 64, 40


def parameter_sets(n: int = N_SETS, seed: int = 2024) -> dict[str, np.ndarray]:
    """Plausible drops around the paper's set-ups (all valid)."""
    rng = np.random.default_rng(seed)
    return {
        "alpha": rng.uniform(0.80, 0.95, n),
        "pivot": rng.uniform(0.100, 0.160, n),
        "height": rng.uniform(0.050, 0.110, n),
        "release_speed": rng.uniform(0.0, 1.5, n),
        "release_angle": rng.uniform(-0.3, 0.0, n),
    }


def best_of(stmt, number: int, repeat: int) -> float:
    """Best time per call (s) over ``repeat`` runs of ``number`` calls."""
    return min(timeit.repeat(stmt, number=number, repeat=repeat)) / number


def ode_sequence(gamma: float, theta_c: float, theta0: float, omega0: float, alpha: float,
                 n_flights: int, half: bool = False) -> np.ndarray:
    """t_C and T_1…T_N by solve_ivp with terminal events (the tests' reference method).

    The fall runs to the event θ = θ_C (tip moving down). A flight starts on θ_C itself, so
    that its contact event cannot fire at the start it first climbs to the turning point
    (event ω = 0), then comes down to θ_C: two calls. With ``half=True`` only the climb is
    integrated and doubled (time-reversal symmetry): one call, a cheaper ODE baseline.
    """

    def rhs(_t, y):
        return [y[1], gamma * np.cos(y[0])]

    def contact(_t, y):
        return y[0] - theta_c

    contact.terminal, contact.direction = True, 1.0

    def turn(_t, y):
        return y[1]

    turn.terminal, turn.direction = True, 1.0

    def integrate(theta, omega, event):
        sol = solve_ivp(rhs, (0.0, 60.0), [theta, omega], method="DOP853", rtol=1e-12,
                        atol=1e-15, events=event)
        return sol.t_events[0][0], sol.y_events[0][0]

    def flight(omega):
        climb, top = integrate(theta_c, -omega, turn)
        if half:
            return 2.0 * climb
        return climb + integrate(top[0], top[1], contact)[0]

    omega_c = np.sqrt(omega0**2 + 2.0 * gamma * (np.sin(theta_c) - np.sin(theta0)))
    times = [integrate(theta0, omega0, contact)[0]]
    times += [flight(alpha**k * omega_c) for k in range(1, n_flights + 1)]
    return np.array(times)


def time_ode(release, theta_c, exact, subset, half):
    """Seconds per sequence, and the worst disagreement with the closed form."""
    worst = 0.0
    start = time.perf_counter()
    for i in subset:
        times = ode_sequence(release.gamma[i], theta_c[i], release.theta0[i], release.omega0[i],
                             release.alpha[i], N_FLIGHTS, half)
        worst = max(worst, np.max(np.abs(times - np.r_[exact.t_c[i], exact.flights[i]])))
    return (time.perf_counter() - start) / len(subset), worst


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ode-subset", type=int, default=4,
                        help="parameter sets given to solve_ivp (scaled to 64; default 4)")
    parser.add_argument("--repeat", type=int, default=7, help="timeit repeats (best is kept)")
    args = parser.parse_args(argv)

    params = parameter_sets()
    kw = {"n_flights": N_FLIGHTS, "stick": STICK, **params}

    def pendulum():
        return bounce_sequence("pendulum", **kw)

    def small_angle():
        return bounce_sequence("small-angle", **kw)

    t_b = small_angle().t_b

    def powerlaw():
        return bounce_sequence("powerlaw", alpha=params["alpha"], t_b=t_b, n_flights=N_FLIGHTS)

    exact = pendulum()
    assert exact.valid.all()
    per_sequence = {}
    for name, fn in (("pendulum closed form", pendulum), ("small-angle", small_angle),
                     ("power law", powerlaw)):
        fn()  # warm up
        per_sequence[name] = best_of(fn, number=200, repeat=args.repeat) / N_SETS

    # The ODE on a subset of the same parameter sets, scaled to the 64.
    release = prepare_release(params["alpha"], params["pivot"], params["height"], STICK,
                              params["release_speed"], params["release_angle"])
    theta_c = np.arcsin(release.sin_theta_c)
    subset = range(min(args.ode_subset, N_SETS))
    ode_per_sequence, worst = time_ode(release, theta_c, exact, subset, half=False)
    half_per_sequence, worst_half = time_ode(release, theta_c, exact, subset, half=True)

    closed = per_sequence["pendulum closed form"]
    ratio = ode_per_sequence / closed
    print(f"forward models, {N_SETS} parameter sets x {N_FLIGHTS} bounces, vectorised; "
          f"best of {args.repeat} timeit repeats")
    print(f"pendulum closed form: {closed * 1e6:.2f} µs/sequence ({N_SETS} × {N_FLIGHTS} bounces)"
          f" | solve_ivp: {ode_per_sequence * 1e3:.1f} ms/sequence | ratio {ratio:,.0f}×")
    print(f"  solve_ivp (DOP853, rtol 1e-12, terminal events; 1 call for the fall + 2 per "
          f"flight) timed on {len(subset)} of the {N_SETS} sets, one pass, and scaled: "
          f"{ode_per_sequence * N_SETS:.2f} s for all {N_SETS}; "
          f"max |closed form − solve_ivp| {worst:.1e} s")
    print(f"  cheaper ODE baseline (climb to the turning point only, doubled: 1 call per "
          f"flight): {half_per_sequence * 1e3:.1f} ms/sequence | ratio "
          f"{half_per_sequence / closed:,.0f}× | max difference {worst_half:.1e} s")
    print(f"small-angle:          {per_sequence['small-angle'] * 1e6:.2f} µs/sequence")
    print(f"power law:            {per_sequence['power law'] * 1e6:.2f} µs/sequence")
    goals = (f"goals: ≤ 10 µs/sequence {'met' if closed <= 10e-6 else 'NOT met'}; "
             f"≥ 1000× faster than solve_ivp {'met' if ratio >= 1000 else 'NOT met'}")
    print(goals)
    load = os.getloadavg()[0]
    print(f"(load average {load:.2f} on {os.cpu_count()} CPUs while timing; a busy machine "
          "inflates both sides, the ratio less so)")


if __name__ == "__main__":
    main()
