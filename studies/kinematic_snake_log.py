"""A robot log from a snake that is *not* principally kinematic: the ``kinematic-snake`` package (Zhang,
Naughton, Parthasarathy & Gazzola, Nat. Commun. 2021; GazzolaLab) — a continuum snake on Coulomb
friction (forward, backward and lateral coefficients) with inertia (Froude number), its curvature
imposed. geogait does not depend on it: ``pip install kinematic-snake`` (and sympy) to re-run this.

The gait is the package's travelling curvature wave κ(s, t) = a(t) cos 2πks + b(t) sin 2πks, whose two
modal amplitudes (a, b) = ε (cos φ, −sin φ) + δ(t) are the log's shape coordinates (curvature units,
ε = 7 by default), perturbed by a smooth δ (a sum of four sinusoids of 1.5–4 per cycle, RMS
``--perturbation`` × ε per joint). The body frame is the package's: centre of mass and mean tangent
angle. The same gait runs at each period of ``--periods`` (one log segment each, separated by a time
gap): a principally kinematic body moves the same per cycle at any period; one with inertia does not.

Writes a CSV with columns time, phase, shape_0/1, shape_velocity_0/1, x, y, heading,
body_velocity_x/y/theta (``geogait fit LOG.csv --shape shape_0,shape_1 --phase phase --shape-velocity
shape_velocity_0,shape_velocity_1 --body-velocity body_velocity_x,body_velocity_y,body_velocity_theta``).

    python studies/kinematic_snake_log.py --froude 1 --periods 1 0.5 --out tests/data/kinematic_snake_froude1.csv

The package (1.0.0, 2021) predates NumPy 2 and SciPy 1.14: its right-hand side is re-stated below with
the same arithmetic and NumPy 2's scalar rules, and SciPy's renamed integrators are aliased.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd
import scipy.integrate
from scipy.integrate import solve_ivp, trapezoid

# the package imports these names from SciPy < 1.14 (its trapz broadcast its samples like NumPy's)
scipy.integrate.trapz = np.trapezoid
scipy.integrate.cumtrapz = scipy.integrate.cumulative_trapezoid
scipy.integrate.simps = scipy.integrate.simpson

import sympy as sp  # noqa: E402
from kinematic_snake.kinematic_snake import KinematicSnake  # noqa: E402


class Snake(KinematicSnake):
    """The package's snake; its right-hand side (``KinematicSnake.__call__``) with NumPy 2's scalar rules."""

    def __call__(self, time, state, *args, **kwargs):
        self.state = state.copy().reshape(-1, 1)
        self._construct(time)
        s = self.centerline.ravel()
        force = self.external_force_distribution(time)
        linear = trapezoid(force, s) / self.froude
        torque = self.external_torque_distribution(force)
        angular = trapezoid(torque / self.froude + self.internal_torque_distribution(time), s) \
            / self.calculate_moment_of_inertia()
        rate = np.empty_like(state)
        rate[:3] = state[3:]
        rate[3:5] = np.ravel(linear)
        rate[5] = np.ravel(angular)[0]
        return rate


def modes(t, period, epsilon, perturbation):
    """(a, b) of the travelling wave at time ``t`` (a sympy symbol or an array), with the perturbation."""
    phase = 2 * sp.pi * t / period
    return (epsilon * sp.cos(phase) + perturbation[0], -epsilon * sp.sin(phase) + perturbation[1])


def smooth_perturbation(t, period, size, rng):
    """Two sums of four sinusoids in ``t`` (1.5–4 per cycle, random phases), RMS ``size`` each."""
    terms = []
    for _ in range(2):
        frequencies = rng.uniform(1.5, 4.0, 4) / period
        phases = rng.uniform(0, 2 * np.pi, 4)
        amplitude = size * np.sqrt(2 / 4)  # four sinusoids of RMS amplitude / √2 each
        terms.append(sum(amplitude * sp.sin(2 * sp.pi * float(f) * t + float(p))
                         for f, p in zip(frequencies, phases, strict=True)))
    return terms


def run_segment(froude, period, cycles, samples, epsilon, perturbation, k, rng, friction):
    t, s = sp.symbols("t s")
    delta = smooth_perturbation(t, period, perturbation * epsilon, rng)
    a, b = modes(t, period, epsilon, delta)
    snake = Snake(froude_number=froude, friction_coefficients=friction)
    snake.set_activation(lambda s_, t_: (a * sp.cos(2 * sp.pi * k * s_) + b * sp.sin(2 * sp.pi * k * s_)).subs(t, t_))
    times = np.arange(cycles * samples) * period / samples
    solution = solve_ivp(snake, (0.0, times[-1]), snake.state.ravel(), method="RK23", t_eval=times, rtol=1e-6,
                         atol=1e-9)
    if not solution.success:
        raise RuntimeError(solution.message)
    x, y, heading, vx, vy, omega = solution.y
    shape = np.stack([sp.lambdify(t, e, "numpy")(times) * np.ones_like(times) for e in (a, b)], axis=1)
    rate = np.stack([sp.lambdify(t, sp.diff(e, t), "numpy")(times) * np.ones_like(times) for e in (a, b)], axis=1)
    cos, sin = np.cos(heading), np.sin(heading)
    return pd.DataFrame({
        "time": times, "phase": np.mod(2 * np.pi * times / period, 2 * np.pi),
        "shape_0": shape[:, 0], "shape_1": shape[:, 1], "shape_velocity_0": rate[:, 0], "shape_velocity_1": rate[:, 1],
        "x": x, "y": y, "heading": heading,
        "body_velocity_x": cos * vx + sin * vy, "body_velocity_y": -sin * vx + cos * vy, "body_velocity_theta": omega})


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--froude", type=float, default=1.0)
    parser.add_argument("--periods", type=float, nargs="+", default=[1.0, 0.5])
    parser.add_argument("--cycles", type=int, default=16, help="cycles per period (the first 2 are dropped)")
    parser.add_argument("--samples", type=int, default=40, help="samples per cycle")
    parser.add_argument("--epsilon", type=float, default=7.0)
    parser.add_argument("--perturbation", type=float, default=0.05, help="δ RMS per joint, fraction of ε")
    parser.add_argument("--wave-number", type=float, default=1.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    friction = {"mu_f": 1.0, "mu_b": 1.5, "mu_lat": 2.0}  # the package's example
    parts, offset = [], 0.0
    for period in args.periods:
        started = time.perf_counter()
        part = run_segment(args.froude, period, args.cycles, args.samples, args.epsilon, args.perturbation,
                           args.wave_number, rng, friction)
        part = part[part["time"] >= 2 * period].assign(time=lambda f, o=offset: f["time"] + o)  # settled
        parts.append(part)
        offset = float(part["time"].iloc[-1]) + 10 * period  # a gap: a new log segment
        print(f"period {period:g} s: {len(part)} samples in {time.perf_counter() - started:.1f} s")
    pd.concat(parts, ignore_index=True).to_csv(args.out, index=False, float_format="%.7g")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
