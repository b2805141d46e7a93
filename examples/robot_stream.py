"""Learning a gait model on a robot, live: the loop a robot driver runs.

Every control tick the driver reads one measurement (time, gait phase, joint angles r, joint
velocities ṙ, body velocity ξ), and the loop

1. **predicts** ξ̂ for the current shape with the model as it stands (what a controller or a
   planner would use, before ξ is measured),
2. **learns** the sample with ``partial_fit`` (one recursive-least-squares update per covering
   phase window; ``model.prior_prediction_`` is the a-priori prediction the update started from),
3. reads the **online Γ** (``model.gamma_``, eq. 6 of the paper: 1 − model error / phase-average
   error, exponentially forgetting),
4. **checkpoints** the model every ``--save-every`` samples and at the end (also on Ctrl-C) with
   ``model.save``, which writes a temporary file and renames it: a crash or power cut during a
   save leaves the previous checkpoint intact.

The simulated 3-link Purcell swimmer (:class:`geogait.simulate.SwimmerStream`) stands in for the
robot: ``SimulatedRobot.read()`` is the one method a real driver has to provide. A robot without
a phase signal or joint-velocity sensors can use :class:`geogait.learn.StreamLearner` instead of the
bare model: it adds online phase estimation from a fitted Phaser and a causal differentiator (the
same loop as ``geogait stream``).

Run::

    python examples/robot_stream.py --quick          # 5 cycles, a few seconds
    python examples/robot_stream.py --cycles 40 --out out/robot_stream
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from geogait.gaits import seed_gait
from geogait.models import AdaptiveGaitModel
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer


class SimulatedRobot:
    """A stand-in robot driver: one measurement per :meth:`read`, like a sensor callback.

    Parameters
    ----------
    n_links : int
    seed : int
    sensor_noise : float
        Noise on the measured body velocity, as a fraction of its RMS.
    """

    def __init__(self, n_links: int = 3, seed: int = 0, sensor_noise: float = 0.1):
        self.gait = seed_gait(n_links - 1)
        self._stream = SwimmerStream(PurcellSwimmer(n_links), self.gait, sensor_noise=sensor_noise, seed=seed)
        self.samples_per_cycle = self._stream.samples_per_cycle
        self.phase_rate = self._stream.phase_rate  # rad per time unit of the commanded phase

    def read(self) -> dict:
        """The next measurement: time, phase (rad), shape, shape_velocity (d,), body_velocity (3,)."""
        sample = self._stream.next_sample()
        return {"time": float(sample.time[0]), "phase": float(sample.phase[0]), "shape": sample.shape[0],
                "shape_velocity": sample.shape_velocity[0], "body_velocity": sample.body_velocity[0]}


def learn(robot: SimulatedRobot, n_samples: int, path: Path, save_every: int) -> dict:
    """Run the loop for ``n_samples`` samples; return a summary (the model is saved at ``path``)."""
    model = AdaptiveGaitModel(gait=robot.gait, phase_rate=robot.phase_rate)
    errors, saves = [], 0
    try:
        for n in range(n_samples):
            sample = robot.read()
            if n > 0:  # 1. predict before ξ is known (the model needs one sample to exist)
                planned = model.predict(sample["phase"], sample["shape"], sample["shape_velocity"])
                errors.append(float(np.linalg.norm(planned - sample["body_velocity"])))
            model.partial_fit(sample["phase"], sample["shape"], sample["shape_velocity"],  # 2. learn
                              sample["body_velocity"])
            gamma = model.gamma_  # 3. online confidence
            if (n + 1) % robot.samples_per_cycle == 0:
                print(f"cycle {(n + 1) // robot.samples_per_cycle:3d}  online Γ {gamma:6.3f}  "
                      f"a-priori |ξ̂ - ξ| {np.linalg.norm(model.prior_prediction_[0] - sample['body_velocity']):.3f}",
                      flush=True)
            if (n + 1) % save_every == 0:  # 4. periodic atomic checkpoint
                model.save(path)
                saves += 1
    finally:  # also on Ctrl-C: keep everything learned
        model.save(path)
        saves += 1
    return {"samples": model.n_samples_seen_, "online_gamma": float(model.gamma_), "saves": saves,
            "mean_prediction_error": float(np.mean(errors)), "model": str(path)}


def main(argv: list[str] | None = None) -> dict:
    """Command line: see the module docstring. Returns the summary it prints."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="5 cycles only")
    parser.add_argument("--cycles", type=int, default=40, help="gait cycles to run")
    parser.add_argument("--links", type=int, default=3, help="links of the simulated swimmer")
    parser.add_argument("--save-every", type=int, default=500, help="checkpoint every N samples")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("out/robot_stream"), help="output folder")
    args = parser.parse_args(argv)
    robot = SimulatedRobot(args.links, args.seed)
    cycles = 5 if args.quick else args.cycles
    args.out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    summary = learn(robot, cycles * robot.samples_per_cycle, args.out / "model.npz", args.save_every)
    summary["samples_per_second"] = summary["samples"] / (time.perf_counter() - started)
    print(json.dumps(summary, indent=1))
    return summary


if __name__ == "__main__":
    main()
