"""Robots for tests: a simulator seen only through the Robot protocol."""


class BareRobot:
    """Only the protocol's members of a SwimmerStream (no truth, no state): a swimmer behind a wall."""

    def __init__(self, stream):
        self._stream = stream
        self.n_joints, self.cycle_period = stream.n_joints, stream.cycle_period

    @property
    def gait(self):
        return self._stream.gait

    def set_gait(self, gait):
        self._stream.set_gait(gait)

    def next_cycle(self):
        return self._stream.next_cycle()
