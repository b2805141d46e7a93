"""What the command-line tests share: the app invoked with any arguments, the check that a command failed in one
line of its own words, and a folder's files (to show that a refused command left them as they were)."""

from pathlib import Path

from typer.testing import CliRunner

from geogait.cli import app


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def one_error_line(result, *fragments):
    """Exit code 1, exactly one 'error: …' line holding every fragment, no traceback, not the bug message
    ("unexpected …, a bug in geogait")."""
    assert result.exit_code == 1, result.output
    errors = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1, result.stderr
    assert "Traceback" not in result.output and "unexpected" not in errors[0], result.output
    assert "a bug in geogait" not in errors[0], result.output
    for fragment in fragments:
        assert fragment in errors[0], errors[0]
    return errors[0]


def snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file() and p.name != ".geogait.lock"}
