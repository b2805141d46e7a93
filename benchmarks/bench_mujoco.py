"""MujocoRobot throughput (issue 9): physics (environment) steps and gait cycles per second.

Each cycle runs ``samples_per_cycle × steps_per_sample`` MuJoCo steps with a PD (or position)
command computed in Python at every step, and reads pose and body velocity at every sample. The
bare ``mujoco.mj_step`` rate of the same model is shown beside it: the difference is the adapter's
per-step Python cost. Skipped (no rows) when mujoco is not installed.
"""

import importlib.util

from run import best_time


def _bare_steps_per_second(robot, n_steps: int = 2000) -> float:
    import mujoco

    model, data = robot.model, mujoco.MjData(robot.model)

    def steps():
        for _ in range(n_steps):
            mujoco.mj_step(model, data)

    return n_steps / best_time(steps, repeats=3, min_time=0.0)


def run():
    if importlib.util.find_spec("mujoco") is None:
        return []
    from geogait.robots import MujocoRobot, gymnasium_swimmer, mujoco_swimmer, purcell_swimmer_xml

    cases = [
        ("geogait:purcell3, PD, 1 s cycle, 500 steps", lambda: mujoco_swimmer(3, seed=0)),
        ("geogait:purcell5, PD, 1 s cycle, 500 steps", lambda: mujoco_swimmer(5, seed=0)),
        ("purcell3 position servos, 1 s cycle, 500 steps",
         lambda: MujocoRobot(purcell_swimmer_xml(3, actuator="position"), control="position", seed=0)),
        ("gymnasium:swimmer, PD, 2 s cycle, 200 steps", lambda: gymnasium_swimmer(seed=0)),
    ]
    rows = []
    for case, make in cases:
        robot = make()
        steps_per_cycle = robot.samples_per_cycle * robot.steps_per_sample
        seconds = best_time(robot.next_cycle, repeats=3, min_time=0.2)
        rows.append(dict(benchmark="MujocoRobot", case=case, value=1 / seconds, unit="cycles/s"))
        rows.append(dict(benchmark="MujocoRobot", case=case, value=steps_per_cycle / seconds, unit="steps/s"))
        rows.append(dict(benchmark="bare mj_step", case=case, value=_bare_steps_per_second(robot), unit="steps/s"))
    return rows
