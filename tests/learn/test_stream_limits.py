"""``geogait stream`` reads lines of bounded length (as the robot bridge does), in either input format."""

import io
import json

import pytest
from _reference import GAIT, lines
from typer.testing import CliRunner

from geogait import GeogaitError
from geogait._files import MAX_LINE_BYTES, bounded_lines
from geogait.cli import app
from geogait.models import AdaptiveGaitModel
from geogait.simulate import simulate
from geogait.systems import PurcellSwimmer

CSV_HEADER = "shape_0,shape_1,body_velocity_x,body_velocity_y,body_velocity_theta\n"


@pytest.mark.parametrize("fmt", ["jsonl", "csv"])
def test_stream_refuses_a_line_longer_than_the_limit_naming_it(tmp_path, fmt):
    """Before: a line of any length was read whole into memory (a line that never ends: until it ran out)."""
    config = tmp_path / "config.json"
    config.write_text(json.dumps(AdaptiveGaitModel(gait=GAIT).to_config()))
    head = lines(simulate(PurcellSwimmer(3), GAIT, 1, seed=4), 0, 5) if fmt == "jsonl" else CSV_HEADER
    result = CliRunner().invoke(app, ["stream", str(config), "--out", str(tmp_path / "m.npz"), "--format", fmt],
                                input=head + " " * (2 * MAX_LINE_BYTES) + "\n")
    assert result.exit_code == 1, result.output
    errors = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "Traceback" not in result.output, result.stderr
    line = 6 if fmt == "jsonl" else 2
    assert f"input line {line} is longer than {MAX_LINE_BYTES} characters" in errors[0], errors[0]


def test_bounded_lines_passes_lines_up_to_the_limit_whole():
    text = "a" * 10 + "\n" + "b" * 9 + "\n" + "c" * 10
    assert list(bounded_lines(io.StringIO(text), limit=10)) == ["a" * 10 + "\n", "b" * 9 + "\n", "c" * 10]
    with pytest.raises(GeogaitError, match="input line 2 is longer than 10 characters"):
        list(bounded_lines(io.StringIO("ok\n" + "x" * 11 + "\n"), limit=10))
