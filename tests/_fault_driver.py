"""A robot driver that injects faults: the reference swimmer behind the JSON-lines bridge, misbehaving on cue.

``python tests/_fault_driver.py '{"fault": "phase_stuck", "cycle": 1, "cycles": 1}'`` speaks the
``geogait-robot`` protocol like ``python -m geogait.robots.driver`` (3-link swimmer, 40 samples per
cycle, period 1 s) and, from cycle ``cycle`` on for ``cycles`` cycles, does what ``fault`` says:

* plausibility faults (geogait must quarantine the cycle): ``phase_stuck``, ``time_scale`` (time
  stamps × ``magnitude``), ``pose_jump`` (first pose of the cycle moved by ``magnitude``),
  ``frozen_joints``, ``ignore_set_gait`` (every cycle, whatever ``cycle`` says), ``velocity_glitch`` (the body
  velocity of sample ``sample``, default the last, set to [``magnitude``, 0, 0]), ``velocity_scale`` (every body
  velocity × ``magnitude``: a unit mismatch);
* protocol faults (geogait must stop with a clear error): ``string_numbers``, ``bool_numbers``, ``huge_numbers``,
  ``bad_utf8``, ``endless_line``, ``huge_error``, ``huge_stderr``, ``deep_json``, ``second_hello``,
  ``repeated_key`` (a key twice in one line), ``clock_per_cycle`` (time stamps restarting at 0);
* ``"hello"``: keys that replace those of the hello line (``{"version": 1.0}``, ``{"cycle_period": 1e300}``).
"""

import json
import sys
import time

from geogait.gaits import FourierGait, Perturbation, seed_gait
from geogait.robots._bridge import PROTOCOL, PROTOCOL_VERSION
from geogait.simulate import SwimmerStream
from geogait.systems import PurcellSwimmer


def main() -> int:
    config = json.loads(sys.argv[1]) if len(sys.argv) > 1 else {}
    fault, first, count = config.get("fault", "none"), config.get("cycle", 0), config.get("cycles", 1)
    magnitude = config.get("magnitude", 1000.0)
    stream = SwimmerStream(PurcellSwimmer(3), seed_gait(2), perturbation=Perturbation.from_std(0.15, frequency=2.0),
                           sensor_noise=0.05, seed=config.get("seed", 0), cycle_period=1.0, samples_per_cycle=40)
    out = sys.stdout.buffer

    def send(message) -> None:
        out.write((json.dumps(message) + "\n").encode())

    hello = {"type": "hello", "protocol": PROTOCOL, "version": PROTOCOL_VERSION, "n_joints": 2, "cycle_period": 1.0,
             "gait": {"order": stream.gait.order, "params": stream.gait.params.tolist()}}
    hello.update(config.get("hello", {}))
    send(hello)
    out.flush()
    cycle = 0
    for line in sys.stdin:
        message = json.loads(line)
        kind = message.get("type")
        if kind == "stop":
            break
        if kind == "set_gait" and fault != "ignore_set_gait":
            stream.set_gait(FourierGait.from_params(message["params"], 2))
        elif kind == "run_cycle":
            active = first <= cycle < first + count
            chunk = stream.next_cycle()
            samples = [{"type": "sample", "time": float(chunk.time[k]), "phase": float(chunk.phase[k]),
                        "shape": chunk.shape[k].tolist(), "shape_velocity": chunk.shape_velocity[k].tolist(),
                        "pose": chunk.pose[k].tolist(), "body_velocity": chunk.body_velocity[k].tolist(),
                        "commanded_shape": chunk.commanded_shape[k].tolist()} for k in range(chunk.n_samples)]
            if active:
                if _protocol_fault(fault, samples, out, magnitude):
                    return 1
                _plausibility_fault(fault, samples, magnitude, config.get("sample", -1))
            for sample in samples:
                send(sample)
            send({"type": "cycle_end"})
            out.flush()
            cycle += 1
    return 0


def _plausibility_fault(fault: str, samples: list, magnitude: float, index: int) -> None:
    if fault == "phase_stuck":
        for sample in samples:
            sample["phase"] = samples[0]["phase"]
    elif fault == "time_scale":
        for sample in samples:
            sample["time"] *= magnitude
    elif fault == "pose_jump":
        samples[0]["pose"][0] += magnitude
    elif fault == "frozen_joints":
        for sample in samples:
            sample["shape"] = list(samples[0]["shape"])
            sample["shape_velocity"] = [0.0, 0.0]
    elif fault == "velocity_glitch":
        samples[index]["body_velocity"] = [magnitude, 0.0, 0.0]
    elif fault == "velocity_scale":
        for sample in samples:
            sample["body_velocity"] = [magnitude * v for v in sample["body_velocity"]]


def _protocol_fault(fault: str, samples: list, out, magnitude: float) -> bool:
    """Write a broken line (and stop, returning True), or change the samples' types in place."""
    if fault == "string_numbers":
        samples[1]["time"] = str(samples[1]["time"])
    elif fault == "bool_numbers":
        samples[1]["shape"][0] = True
    elif fault == "huge_numbers":
        samples[1]["pose"][0] = 1e300
    elif fault == "bad_utf8":
        out.write(b'{"type": "sample", "time": "\xff\xfe"}\n')
    elif fault == "endless_line":
        out.write(b'{"type": "sample", "pad": "' + b"x" * (8 << 20))
    elif fault == "huge_error":
        out.write((json.dumps({"type": "error", "message": "E" * int(magnitude)}) + "\n").encode())
    elif fault == "huge_stderr":
        sys.stderr.write("S" * 3_000_000 + "\n")
        sys.stderr.flush()
    elif fault == "second_hello":
        out.write((json.dumps({"type": "hello", "protocol": PROTOCOL, "version": PROTOCOL_VERSION, "n_joints": 5,
                               "cycle_period": 100.0}) + "\n").encode())
        return False
    elif fault == "deep_json":
        out.write(b"[" * 100_000 + b"]" * 100_000 + b"\n")
    elif fault == "repeated_key":  # (json.dumps cannot write one)
        out.write(b'{"type": "sample", "time": 1.5, "time": 1.6}\n')
    elif fault == "clock_per_cycle":  # a driver whose time stamps restart every cycle
        start = samples[0]["time"]
        for sample in samples:
            sample["time"] -= start
        return False
    else:
        return False
    if fault in ("string_numbers", "bool_numbers", "huge_numbers"):
        return False
    out.flush()
    time.sleep(5 if fault == "endless_line" else 0.2)
    return True


if __name__ == "__main__":
    sys.exit(main())
