"""RLS bank update throughput (issue 3): one sample at a time (compiled path and NumPy reference, issue 26),
and batched over 50 trials; against
an equivalent bank of padasip ``FilterRLS`` filters (one per window per output). Shape-space model
(issue 10): one cycle of learning on the 9-link swimmer with the symmetric degree-3 and degree-4 bases,
and a filter's samples as one block (``RLSBank.update_sequence``) against one rank-one update each."""

import numpy as np
import padasip
from run import best_time

from geogait import _kernels
from geogait.gaits import seed_gait
from geogait.models import AdaptiveGaitModel, RLSBank, ShapeSpaceModel
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer


def _padasip_bank(model, run, n_samples):
    """Same windows, regressors, λ and δ₀ as ``model``; one FilterRLS per window and output."""
    from geogait.models import regressors

    windows, gait = model.windows_, model.gait_
    n = model.window_weights_.shape[-2]
    filters = [[padasip.filters.FilterRLS(n, mu=model.forgetting_factor, eps=1 / model.initial_covariance)
                for _ in range(3)] for _ in range(windows.n_windows)]
    centres = windows.centres
    nominal, nominal_rate = gait.shape(centres), 2 * np.pi * gait.velocity(centres)
    cover = windows.cover(run.phase[:n_samples])

    def feed():
        for s in range(n_samples):
            for m in np.flatnonzero(cover[s]):
                x = regressors(run.shape[s] - nominal[m], run.shape_velocity[s] - nominal_rate[m])
                for k in range(3):
                    filters[m][k].adapt(run.body_velocity[s, k], x)

    return feed


def run():
    rows = []
    for links in (3, 5, 9):
        swimmer, gait = PurcellSwimmer(links), seed_gait(links - 1)
        single = simulate(swimmer, gait, 2, seed=0)
        args = (single.phase, single.shape, single.shape_velocity, single.body_velocity)

        def one_at_a_time(args=args, gait=gait):
            model = AdaptiveGaitModel(gait=gait)
            for s in range(200):
                model.partial_fit(args[0][s], args[1][s], args[2][s], args[3][s])

        seconds = best_time(one_at_a_time, repeats=5)
        target = {3: ">= 50 000", 9: ">= 10 000"}.get(links, "")
        one_rate = 200 / seconds
        rows.append(dict(benchmark="rls update", case=f"{links}-link, one sample at a time (compiled)",
                         value=one_rate, unit="samples/s", target=target))
        _kernels.ENABLED = False  # the same samples through the NumPy reference path, side by side
        try:
            reference_seconds = best_time(one_at_a_time, repeats=3)
        finally:
            _kernels.ENABLED = True
        rows.append(dict(benchmark="rls update", case=f"{links}-link, one sample at a time (NumPy reference)",
                         value=200 / reference_seconds, unit="samples/s"))
        trials = simulate(swimmer, gait, 10, seed=1, n_trials=50)
        batch_args = (trials.phase, trials.shape, trials.shape_velocity, trials.body_velocity)
        seconds = best_time(lambda a=batch_args, g=gait: AdaptiveGaitModel(gait=g).fit(*a), repeats=3)
        target = {3: ">= 100 000", 9: ">= 20 000"}.get(links, "")
        rows.append(dict(benchmark="rls update", case=f"{links}-link, batch of 50 trials x 1000 samples",
                         value=50 * 1000 / seconds, unit="samples/s", target=target))
        reference = AdaptiveGaitModel(gait=gait).fit(*args)
        n_padasip = 100 if links < 9 else 40
        padasip_seconds = best_time(_padasip_bank(reference, single, n_padasip), repeats=1, min_time=0.0)
        ours = best_time(lambda a=args, g=gait, k=n_padasip: AdaptiveGaitModel(gait=g).fit(*(x[:k] for x in a)),
                         repeats=3)
        rows.append(dict(benchmark="padasip FilterRLS bank", case=f"{links}-link, one trial, {n_padasip} samples",
                         value=n_padasip / padasip_seconds, unit="samples/s"))
        rows.append(dict(benchmark="speed-up vs padasip", case=f"{links}-link, same {n_padasip} samples",
                         value=padasip_seconds / ours, unit="x"))
        rows.append(dict(benchmark="speed-up vs padasip", case=f"{links}-link, both one sample at a time",
                         value=one_rate / (n_padasip / padasip_seconds), unit="x", target="> 1"))
    return rows + run_shape_space()


def run_shape_space():
    rows = []
    swimmer, gait = PurcellSwimmer(9), seed_gait(8)
    cycles = simulate(swimmer, gait, 2, seed=0, sensor_noise=0.1)
    first, second = ((a[s] for a in (cycles.phase, cycles.shape, cycles.shape_velocity, cycles.body_velocity))
                     for s in (slice(0, 100), slice(100, 200)))
    first, second = tuple(first), tuple(second)
    for degree in (3, 4):
        model = ShapeSpaceModel(degree=degree, symmetry="mirror+reversal", forgetting_factor=0.9999)
        model.partial_fit(*first)  # then learn the second cycle again and again: the cost does not change
        rows.append(dict(benchmark="shape-space model", case=f"9-link, degree {degree}, symmetric, one cycle",
                         value=1 / best_time(lambda m=model: m.partial_fit(*second), repeats=3), unit="cycles/s"))
    rng = np.random.default_rng(0)
    n = 1468  # the 9-link degree-4 model's even blocks
    x, y = rng.normal(size=(1, 100, n)), rng.normal(size=(1, 100, 1))

    def sample_by_sample():
        bank = RLSBank((), 1, n, 1, 0.9999, 100.0)
        for i in range(100):
            bank.update(x[:, i], y[:, i], np.ones(1, bool))

    block = best_time(lambda: RLSBank((), 1, n, 1, 0.9999, 100.0).update_sequence(x, y), repeats=3)
    single = best_time(sample_by_sample, repeats=1, min_time=0.0)
    rows.append(dict(benchmark="rls sequence", case=f"{n} regressors, 100 samples as one block",
                     value=100 / block, unit="samples/s"))
    rows.append(dict(benchmark="speed-up vs rank-one updates", case=f"{n} regressors, same 100 samples",
                     value=single / block, unit="x"))
    return rows
