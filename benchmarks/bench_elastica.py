"""ElasticaSnake throughput (issue 27's robot benchmark runs thousands of its cycles): cycles per second.

Each cycle runs ``samples_per_cycle × steps_per_sample`` PyElastica position-Verlet steps with the
rest curvature set from the commanded modal shape before every step, and measures curvature, pose
and body velocity from the rod's nodes at every sample. Skipped (no rows) when pyelastica is not
installed.
"""

import importlib.util

from run import best_time


def run():
    if importlib.util.find_spec("elastica") is None:
        return []
    from geogait.robots import elastica_snake

    cases = [
        ("default: 20 elements, 1 s cycle, 4000 steps, planar", lambda: elastica_snake(seed=0)),
        ("free in 3-D (planar=False)", lambda: elastica_snake(seed=0, planar=False)),
    ]
    rows = []
    for case, make in cases:
        snake = make()
        steps_per_cycle = snake.samples_per_cycle * snake.steps_per_sample
        seconds = best_time(snake.next_cycle, repeats=3, min_time=0.0)
        rows.append(dict(benchmark="ElasticaSnake", case=case, value=1 / seconds, unit="cycles/s"))
        rows.append(dict(benchmark="ElasticaSnake", case=case, value=steps_per_cycle / seconds, unit="steps/s"))
    return rows
