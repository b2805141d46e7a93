"""Online phase against offline phase at any period and under a drifting rate (issue 25).

The 3-link swimmer (seed gait, perturbation std 0.15 rad) simulated by
:func:`geogait.simulate.simulate_rate`: a Phaser is fitted on one record and both estimators are
applied to another of the same setting (``--seeds`` pairs, ``--cycles`` cycles each). Settings:

* ``window/period`` 1, 1.5, 2, 2.3, 2.5, 3: the OnlinePhaser window is 200 samples and the period
  200 / ratio samples (mostly not a whole number of samples);
* ``drift up`` / ``drift down``: 100 samples per cycle at the nominal rate, the rate ramping
  linearly from 0.8 to 1.2 (or 1.2 to 0.8) times nominal over the record (window 200);

each without and with shape noise of 10 % of the joint angles' RMS. Errors are circular
distances to the commanded phase after removing one constant offset per record (the offline
estimate's), pooled over records, from the end of the online warm-up (one cycle) on. Columns:
median and 95th percentile of the offline ``Phaser.transform`` (whole record) and of the online
``OnlinePhaser.update`` (causal, one sample at a time); ``delay``: the online estimate's mean
signed error in samples (negative: behind); ``old``: median of the former online estimate (the
newest sample of a Phaser run on the window, every 7th sample, for comparison); ``jump``: the largest
step of ``transform(unwrap=True)`` (rad), and ``count``: the largest error of the cycle count it
implies, in cycles.

    python studies/online_phase.py [--seeds 5] [--cycles 30] [--quick]
"""

import argparse

import numpy as np

from geogait.gaits import seed_gait
from geogait.phase import OnlinePhaser, Phaser
from geogait.phase._phaser import _correct, _protophase, combine_phases
from geogait.simulate import simulate_rate
from geogait.systems import PurcellSwimmer

WINDOW = 200
SETTINGS = [(f"window/period {r:g}", WINDOW / r, (1.0, 1.0)) for r in (1.0, 1.5, 2.0, 2.3, 2.5, 3.0)] + [
    ("drift up 0.8->1.2", WINDOW / 2, (0.8, 1.2)), ("drift down 1.2->0.8", WINDOW / 2, (1.2, 0.8))]


def windowed(phaser: Phaser, x: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """The former OnlinePhaser at samples ``ends - 1``: the raw Hilbert phase of the newest sample of
    the last ``WINDOW`` samples (Phaser steps 1-5, without the edge blending ``transform`` now does)."""
    out = np.empty(len(ends))
    for index, end in enumerate(ends):
        theta = _protophase(phaser._zscore(x[max(0, end - WINDOW):end]))[-1:]
        combined = combine_phases(_correct(theta, phaser.channel_coefficients_), phaser.offsets_, phaser.weights_)
        out[index] = _correct(combined, phaser.final_coefficients_)[0] - phaser.zero_
    return out


def errors(estimate, truth, offset):
    return np.angle(np.exp(1j * (estimate - truth - offset)))


def run_setting(spc, ramp, noise, seeds, cycles, old):
    swimmer, gait = PurcellSwimmer(3), seed_gait(2)
    pooled = {"offline": [], "online": [], "old": []}
    delays, jumps, counts = [], [], []
    for seed in seeds:
        options = dict(samples_per_cycle=spc, rate_ramp=ramp, shape_noise=noise)
        train = simulate_rate(swimmer, gait, cycles, seed=seed, **options)
        test = simulate_rate(swimmer, gait, cycles, seed=seed + 10_000, **options)
        phaser = Phaser().fit(train.shape)
        truth = test.phase + 2 * np.pi * test.cycle
        offline = phaser.transform(test.shape, unwrap=True)
        offset = np.angle(np.mean(np.exp(1j * (offline - truth))))
        online_phaser = OnlinePhaser(phaser, window=WINDOW)
        online = np.array([np.nan if (p := online_phaser.update(s)) is None else p for s in test.shape])
        start = int(np.ceil(spc))  # after one cycle: the online warm-up
        keep = slice(start, None)
        pooled["offline"].append(np.abs(errors(offline, truth, offset))[keep])
        signed = errors(online, truth, offset)[keep]
        pooled["online"].append(np.abs(signed))
        delays.append(np.mean(signed) / np.mean(np.diff(truth)))
        if old:  # every 7th sample (it runs a Phaser per sample)
            ends = np.arange(start + 1, len(truth) + 1, 7)
            pooled["old"].append(np.abs(errors(windowed(phaser, test.shape, ends), truth[ends - 1], offset)))
        jumps.append(np.abs(np.diff(offline)).max())
        counts.append(abs((offline[-1] - offline[0]) - (truth[-1] - truth[0])) / (2 * np.pi))
    stats = {k: (np.median(np.concatenate(v)), np.percentile(np.concatenate(v), 95)) if v else (np.nan, np.nan)
             for k, v in pooled.items()}
    return stats, float(np.mean(delays)), float(np.max(jumps)), float(np.max(counts))


def main(seeds: int, cycles: int, old: bool) -> list[str]:
    seed_list = list(range(seeds))
    header = (f"{'setting':<22}{'noise':>6}  {'offline med/p95':>16}  {'online med/p95':>15}  {'ratio':>5}"
              f"  {'delay':>6}  {'old med':>7}  {'jump':>5}  {'count':>5}")
    print(header, flush=True)
    failures = []
    for noise in (0.0, 0.1):
        for label, spc, ramp in SETTINGS:
            stats, delay, jump, count = run_setting(spc, ramp, noise, seed_list, cycles, old)
            (off_m, off_p), (on_m, on_p), (old_m, _) = stats["offline"], stats["online"], stats["old"]
            print(f"{label:<22}{noise:>6.1f}  {off_m:>8.3f} / {off_p:<5.2f}  {on_m:>7.3f} / {on_p:<5.2f}"
                  f"  {on_m / off_m:>5.2f}  {delay:>+6.2f}  {'-' if np.isnan(old_m) else f'{old_m:.3f}':>7}"
                  f"  {jump:>5.2f}  {count:>5.2f}", flush=True)
            if not (on_m <= 2 * off_m and on_p <= 0.3 and jump < np.pi):
                failures.append(f"{label}, noise {noise:g}")
    print("acceptance (online median <= 2x offline, online p95 <= 0.3 rad, no 2π jump): "
          + ("met in every setting" if not failures else "NOT met: " + "; ".join(failures)))
    return failures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5, help="record pairs per setting")
    parser.add_argument("--cycles", type=int, default=30, help="cycles per record")
    parser.add_argument("--no-old", action="store_true", help="skip the former windowed estimate (slow)")
    parser.add_argument("--quick", action="store_true", help="1 pair of 8-cycle records, no former estimate")
    arguments = parser.parse_args()
    if arguments.quick:
        main(1, 8, False)
    else:
        main(arguments.seeds, arguments.cycles, not arguments.no_old)
