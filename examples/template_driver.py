"""Template: a robot driver that speaks geogait's JSON-lines protocol on stdin and stdout.

Write a driver like this one when your robot's code is not Python, or runs in its own process or on
another computer. geogait starts the driver and talks to it, one JSON object per line::

    geogait optimize --robot "python examples/template_driver.py" --cycles 30 --out out/my-robot

The protocol part below uses only ``json`` and ``math``, so it translates line by line to C++, MATLAB or
Rust. The body behind it is the stand-in of ``template_robot.py``: replace ``StandInBody`` with your
hardware (send joint targets, wait one tick, read the encoders and the motion-capture pose).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # (the stand-in body lives beside this file)
from template_robot import StandInBody  # noqa: E402

N_JOINTS = 2
CYCLE_PERIOD = 2.0  # seconds per gait cycle
SAMPLES_PER_CYCLE = 50
SEED_GAIT = [0.0, 1.0, 0.0, 0.0, 0.0, 1.0]  # order 1: joint 0 = cos φ, joint 1 = sin φ


def joint_angles(params: list, order: int, phase: float) -> list:
    """A Fourier gait at one phase: per joint a_0 + Σ_k (a_k cos kφ + b_k sin kφ), params [a_0, a_1..a_K, b_1..b_K]."""
    width = 2 * order + 1
    return [a[0] + sum(a[k] * math.cos(k * phase) + a[order + k] * math.sin(k * phase) for k in range(1, order + 1))
            for a in (params[j * width: (j + 1) * width] for j in range(N_JOINTS))]


def joint_rates(params: list, order: int, phase: float) -> list:
    """Its time derivative (rad/s): dθ/dφ times the phase rate 2π / CYCLE_PERIOD."""
    width = 2 * order + 1
    rate = 2 * math.pi / CYCLE_PERIOD
    return [rate * sum(k * (a[order + k] * math.cos(k * phase) - a[k] * math.sin(k * phase))
                       for k in range(1, order + 1))
            for a in (params[j * width: (j + 1) * width] for j in range(N_JOINTS))]


def excitation_at(excitation: dict | None, phase: float) -> tuple[list, list]:
    """The exploration geogait sent for this cycle (δ, δ̇ on M uniform phases), interpolated at ``phase``."""
    if excitation is None:
        return [0.0] * N_JOINTS, [0.0] * N_JOINTS
    values = []
    for name in ("shape", "shape_velocity"):
        grid = excitation[name]
        m = len(grid)
        position = phase / (2 * math.pi) * m
        k = int(position) % m
        weight = position - int(position)
        values.append([(1 - weight) * grid[k][j] + weight * grid[(k + 1) % m][j] for j in range(N_JOINTS)])
    return values[0], values[1]


def send(message: dict) -> None:
    sys.stdout.write(json.dumps(message) + "\n")


def run_cycle(body: StandInBody, gait: dict, excitation: dict | None, clock: float) -> None:
    """Run one cycle of ``gait`` plus ``excitation`` and send its samples, then ``cycle_end``."""
    dt = CYCLE_PERIOD / SAMPLES_PER_CYCLE
    for k in range(SAMPLES_PER_CYCLE):
        phase = 2 * math.pi * k / SAMPLES_PER_CYCLE
        delta, delta_rate = excitation_at(excitation, phase)
        target = [a + b for a, b in zip(joint_angles(gait["params"], gait["order"], phase), delta, strict=True)]
        body.step(target, dt)
        shape, pose = body.read()
        # joint rates: the commanded ones here; differentiate your encoders if the joints lag noticeably.
        # body_velocity is left out: geogait computes it from consecutive poses.
        rate = [a + b for a, b in zip(joint_rates(gait["params"], gait["order"], phase), delta_rate, strict=True)]
        send({"type": "sample", "time": clock + k * dt, "phase": phase, "shape": shape.tolist(),
              "shape_velocity": rate, "pose": pose.tolist(), "commanded_shape": target})
    send({"type": "cycle_end"})
    sys.stdout.flush()


def main() -> int:
    gait = {"order": 1, "params": SEED_GAIT}
    body = StandInBody(joint_angles(gait["params"], gait["order"], 0.0), seed=0)
    send({"type": "hello", "protocol": "geogait-robot", "version": 2, "n_joints": N_JOINTS,
          "cycle_period": CYCLE_PERIOD, "gait": gait, "joint_ranges": [[-1.4, 1.4], [-1.4, 1.4]],
          "excitation": True})  # geogait sends the exploration to add to each cycle
    sys.stdout.flush()
    clock = 0.0  # one clock for the whole run: time stamps keep increasing across cycles
    for line in sys.stdin:
        message = json.loads(line)
        if message["type"] == "set_gait":
            gait = {"order": message["order"], "params": message["params"]}
        elif message["type"] == "run_cycle":
            run_cycle(body, gait, message.get("excitation"), clock)
            clock += CYCLE_PERIOD
        elif message["type"] == "stop":
            break
    return 0


if __name__ == "__main__":
    sys.exit(main())
