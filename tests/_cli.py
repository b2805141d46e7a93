"""What the command-line tests share: the check that a command failed in one line of its own words."""


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
