"""Reference driver of the JSON-lines robot bridge: the built-in Purcell swimmer as a process.

``python -m geogait.robots.driver --links 3`` speaks the ``geogait-robot`` protocol
(:mod:`geogait.robots._bridge`) on stdin / stdout, so ``geogait optimize --robot "python -m
geogait.robots.driver"`` optimises a robot that lives in another process. Copy its loop for a
driver in any language: read a line, act on its ``type``, write lines, flush.

``--robot elastica`` serves PyElastica's continuum snake (:class:`~geogait.robots.ElasticaSnake`,
``pip install 'geogait[elastica]'``) instead, so ``geogait optimize --robot "python -m
geogait.robots.driver --robot elastica" --objective forward`` optimises it with no glue of one's own.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

from .._validation import GeogaitError
from ..gaits import FourierGait, Perturbation, seed_gait
from ..simulate import SwimmerStream
from ..systems import PurcellSwimmer
from ._bridge import PROTOCOL, PROTOCOL_VERSION


def _arguments(argv):
    parser = argparse.ArgumentParser(prog="python -m geogait.robots.driver", description=__doc__.splitlines()[0])
    parser.add_argument("--robot", choices=("swimmer", "elastica"), default="swimmer",
                        help="the built-in Purcell swimmer (default) or PyElastica's continuum snake")
    parser.add_argument("--links", type=int, default=None, help="links of the Purcell swimmer (default 3)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--noise", type=float, default=None,
                        help="swimmer: sensor noise on ξ, fraction of RMS (default 0.1)")
    parser.add_argument("--perturbation", type=float, default=None,
                        help="std of δ in rad (default 0.15; the snake: 15 %% of its seed amplitude)")
    parser.add_argument("--period", type=float, default=1.0, help="seconds per cycle (default 1)")
    parser.add_argument("--samples-per-cycle", type=int, default=100, help="samples per cycle (default 100)")
    parser.add_argument("--poses-only", action="store_true", help="send poses but no body velocities")
    parser.add_argument("--shape-constraints", default=None,
                        help="JSON rows [a_0, ..., a_(d-1), b] (a · shape <= b) the hello declares, e.g. "
                             "'[[1, -1, 1.6], [-1, 1, 1.6]]' for |r0 - r1| <= 1.6")
    parser.add_argument("--protocol", type=int, choices=(1, 2), default=2,
                        help="protocol version to speak (default 2: the swimmer runs the exploration geogait sends)")
    return parser.parse_args(argv)


def _robot(args):
    """(robot, front–back symmetric) for the parsed options."""
    # eq. 8 at the same number of oscillations per cycle whatever the period
    perturbation = (None if args.perturbation is None
                    else Perturbation.from_std(args.perturbation, frequency=2.0 / args.period))
    if args.robot == "elastica":
        for name, value in (("--links", args.links), ("--noise", args.noise)):
            if value is not None:
                raise SystemExit(f"error: {name} applies to the swimmer, not to --robot elastica")
        from ._elastica import ElasticaSnake

        return ElasticaSnake(cycle_period=args.period, samples_per_cycle=args.samples_per_cycle,
                             perturbation=perturbation, seed=args.seed), False
    swimmer = PurcellSwimmer(3 if args.links is None else args.links)
    perturbation = Perturbation.from_std(0.15, frequency=2.0 / args.period) if perturbation is None else perturbation
    return SwimmerStream(swimmer, seed_gait(swimmer.n_joints), perturbation=perturbation,
                         sensor_noise=0.1 if args.noise is None else args.noise, seed=args.seed,
                         cycle_period=args.period, samples_per_cycle=args.samples_per_cycle), True


def main(argv=None) -> int:
    args = _arguments(argv)
    if not 0 < args.period < math.inf:  # (before it divides anything)
        raise SystemExit(f"error: --period must be a finite number of seconds > 0, got {args.period}")
    try:
        stream, symmetric = _robot(args)
    except GeogaitError as error:  # a bad option: one line and exit code 1, as the geogait commands end
        raise SystemExit(f"error: {error}") from None
    out = sys.stdout

    def send(message):
        out.write(json.dumps(message) + "\n")

    excitation = args.protocol >= 2 and hasattr(stream, "set_excitation")
    hello = {"type": "hello", "protocol": PROTOCOL, "version": min(args.protocol, PROTOCOL_VERSION),
             "n_joints": stream.n_joints, "cycle_period": args.period, "front_back_symmetric": symmetric,
             "mirror_symmetric": True,  # the swimmer (any links) and the snake both read the same in a mirror
             "gait": {"order": stream.gait.order, "params": stream.gait.params.tolist()}}
    if excitation:
        hello["excitation"] = True
    if args.shape_constraints is not None:
        try:
            hello["shape_constraints"] = json.loads(args.shape_constraints)
        except json.JSONDecodeError as error:
            raise SystemExit(f"error: --shape-constraints must be JSON rows [a_0, ..., a_(d-1), b]: {error}") from None
    if hasattr(stream, "chain_geometry"):  # the swimmer's chain, the snake's elements: for the resistance model
        geometry = stream.chain_geometry()
        hello["chain"] = {"link_lengths": [float(v) for v in geometry["link_lengths"]],
                          "body_frame": geometry["body_frame"], "frame_offset": geometry["frame_offset"]}
        if geometry.get("shape_map") is not None:
            hello["chain"]["shape_map"] = [[float(v) for v in row] for row in geometry["shape_map"]]
    send(hello)
    out.flush()
    for line in sys.stdin:
        message = json.loads(line)
        kind = message.get("type")
        if kind == "stop":
            break
        if kind == "set_gait":
            stream.set_gait(FourierGait.from_params(message["params"], stream.n_joints))
        elif kind == "run_cycle":
            if excitation and "excitation" in message:
                stream.set_excitation(message["excitation"]["shape"], message["excitation"]["shape_velocity"])
            cycle = stream.next_cycle()
            for k in range(cycle.n_samples):
                sample = {"type": "sample", "time": float(cycle.time[k]), "phase": float(cycle.phase[k]),
                          "shape": cycle.shape[k].tolist(), "shape_velocity": cycle.shape_velocity[k].tolist(),
                          "pose": cycle.pose[k].tolist(), "commanded_shape": cycle.commanded_shape[k].tolist()}
                if not args.poses_only:
                    sample["body_velocity"] = cycle.body_velocity[k].tolist()
                send(sample)
            send({"type": "cycle_end"})
            out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
