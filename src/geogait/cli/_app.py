"""The typer application objects every command module registers on, and the one error path.

Every command of ``geogait`` ends in one of two ways: its normal output, or one line
``error: <message>`` on stderr and exit code 1. That holds for bad option values (typer/click
usage errors), the library's :class:`~geogait.GeogaitError`, operating-system errors (an output
path that is a file or read-only, a missing folder), unreadable CSV/Parquet files, and, as a last
resort, for anything unexpected (then the line says it is a bug; ``GEOGAIT_TRACEBACK=1`` shows the
traceback). Library warnings are printed as ``warning: <message>`` lines. Commands do not need to
catch anything themselves: the handling lives in :class:`GeogaitGroup`, the click group of the
application.
"""

from __future__ import annotations

import inspect
import os
import re
import signal
import sys
import threading
import warnings
from collections.abc import Callable
from contextlib import contextmanager

import typer
from typer.core import TyperCommand, TyperGroup
from typer.exceptions import TyperException

from .._validation import GeogaitError

__all__ = ["GeogaitGroup", "app", "error_message", "figure_app", "help_from", "in_cli_words"]


def _input_errors() -> tuple[type[BaseException], ...]:
    """Exception types that mean bad input or a bad environment, not a bug."""
    import pandas as pd
    import pyarrow as pa

    return (GeogaitError, OSError, pd.errors.ParserError, pd.errors.EmptyDataError, pa.ArrowException)


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


#: Library parameters that an option sets under another name (else the option of the parameter's name, if any).
_OPTION_OF = {"random_state": "--seed", "n_links": "--links", "n_windows": "--windows", "window": "--smoothing-window",
              "sensor_noise": "--noise", "n_trials": "--trials", "n_cycles": "--cycles", "drag_ratios": "--drag-ratio"}
#: The library's message about a parameter (``_validation.fail``), or one about an option in its words.
_PARAMETER_ERROR = re.compile(r"^The '(?P<name>[^']+)' (?:parameter of (?P<owner>[\w. ]+?)|option) must be "
                              r"(?P<expected>.+?)\. Got (?P<got>.+?) instead\.(?P<rest>.*)$", re.S)
#: What a message about the reader of a log file (read_log) or of an input line (stream) is said of: the log and
#: its columns, the line and its keys.
_INPUT_OWNER = re.compile(r"^(?:read_log|input line \d+)$")
#: An option named in the library's manner ("The '--x' option"), said the CLI's way ("--x").
_OPTION_NAMED = re.compile(r"(?:The )?'(--[\w-]+)' option")
#: What typer says of a bad option value, in the CLI's words ("must be …"); {given} is the value given.
_TYPER_WORDS = tuple((re.compile(pattern, re.S), words) for pattern, words in (
    (r"^expected (?P<expected>.+?),? got (?P<got>.+?)\.?$", "must be {expected}; got {got}."),
    (r"^(?:Value error, )?(?P<got>.+) is not one of (?P<choices>.+?)\.?$", "must be one of {choices}; got {got}."),
    (r"^Input should be greater than or equal to (?P<bound>\S+)$", "must be ≥ {bound}; got {given}."),
    (r"^Input should be less than or equal to (?P<bound>\S+)$", "must be ≤ {bound}; got {given}."),
    (r"^Input should be greater than (?P<bound>\S+)$", "must be > {bound}; got {given}."),
    (r"^Input should be less than (?P<bound>\S+)$", "must be < {bound}; got {given}."),
    (r"^Input should be a valid integer", "must be an integer; got {given}."),
    (r"^Input should be a valid number", "must be a number; got {given}.")))


def _command_of(group, args) -> tuple:
    """The command that ``args`` run in ``group``, and the arguments left for it."""
    command, rest = group, list(args)
    while rest and rest[0] in getattr(command, "commands", {}):
        command = command.commands[rest.pop(0)]
    return command, rest


def _given(option: str, args) -> str:
    """The value given to ``option`` in ``args``, as typed (quoted unless a number)."""
    value = ""
    for position, token in enumerate(args):
        name, equals, text = str(token).partition("=")
        if name == option:
            value = text if equals else (str(args[position + 1]) if position + 1 < len(args) else "")
    try:
        float(value)
    except ValueError:
        return repr(value)
    return value


def in_cli_words(text: str, options: dict[str, str]) -> str:
    """A message about a library parameter that an option sets, said of the option: "--x must be …; got …."

    ``options`` maps the running command's parameter names to their options; other messages stay as they are.
    """
    match = _PARAMETER_ERROR.match(text)
    if match is None:
        return _OPTION_NAMED.sub(r"\1", text)
    name = match["name"]
    option = name if name.startswith("--") else options.get(name)
    if option is None and _OPTION_OF.get(name) in options.values():
        option = _OPTION_OF[name]
    if option is None and match["owner"] is not None and _INPUT_OWNER.match(match["owner"]):
        option = _input_named(name, match["owner"])
    if option is None:
        return text
    expected = _options_named(match["expected"], options)
    return _OPTION_NAMED.sub(r"\1", f"{option} must be {expected}; got {match['got']}.{match['rest']}")


def _options_named(text: str, options: dict[str, str]) -> str:
    """Library parameter names (snake_case) within a message, said as the options that set them."""
    for name, option in options.items():
        if "_" in name:
            text = re.sub(rf"(?<![\w-]){re.escape(name)}(?!\w)", option, text)
    return text


def _input_named(name: str, owner: str) -> str | None:
    """A parameter of the log reader or of a streamed input line, said of the user's input: "the log", "the log's
    column 'x'", "input line 3", "input line 3's 'shape'"; None for a setting of the reader no option gave."""
    if owner == "read_log":
        from ..io import read_log

        if name == "source":
            return "the log"
        return None if name in inspect.signature(read_log).parameters else f"the log's column '{name}'"
    return owner if name in ("record", "row", "header") else f"{owner}'s '{name}'"


def _bad_value(error, args) -> str:
    """A bad option value (typer's or a command's BadParameter) as "--x must be …; got …."."""
    hint = error.param_hint if error.param_hint is not None else error.param.opts[0]
    hint = hint if isinstance(hint, str) else hint[0]
    hint = hint.strip("'")
    message = _one_line(error.message)
    for pattern, words in _TYPER_WORDS:
        match = pattern.match(message)
        if match:
            fields = match.groupdict()
            if "choices" in fields:
                fields["choices"] = fields["choices"].replace("'", "")
            if "bound" in fields:
                fields["bound"] = f"{float(fields['bound']):.4g}"
            return f"{hint} {words.format(given=_given(hint, args), **fields)}"
    return f"{hint}: {message}"


def error_message(error: BaseException, command=None, args=()) -> str:
    """The one-line message of ``error`` for the ``error: …`` line (no traceback), in the words of the options of
    ``command`` (the running command, given ``args``)."""
    is_bad_value = isinstance(error, typer.BadParameter) and type(error).__name__ == "BadParameter"
    if is_bad_value and (error.param_hint is not None or error.param is not None):
        return _bad_value(error, args)
    if isinstance(error, TyperException) and hasattr(error, "format_message"):  # usage errors, missing values
        return _one_line(error.format_message())
    if isinstance(error, OSError) and error.strerror:
        names = [name for name in (error.filename, error.filename2) if name is not None]
        return _one_line(f"{error.strerror}: {' → '.join(str(n) for n in names)}" if names else error.strerror)
    if isinstance(error, GeogaitError):
        options = {param.name: param.opts[0] for param in getattr(command, "params", []) if param.opts}
        return _one_line(in_cli_words(str(error), options))
    kind = type(error).__name__
    if kind == "SweepFailedError":  # trials of an experiment failed: their summary, without the tracebacks
        summary = str(error).split(" Traceback of trial")[0].split("\nTraceback")[0]
        return _one_line(f"{summary} (the failed trials' tracebacks are in the exception's failures)")
    if isinstance(error, _input_errors()):
        return _one_line(f"unreadable input ({kind}): {error}")
    return _one_line(f"unexpected {kind}: {error} (a bug in geogait; run with GEOGAIT_TRACEBACK=1 for the "
                     "traceback and please report it)")


#: A library warning about the values of one parameter ("The 'shape' values of AdaptiveGaitModel.partial_fit …").
_VALUES_WARNING = re.compile(r"^The '(?P<name>\w+)' values of [\w.]+ ")


@contextmanager
def _warnings_as_lines(command=None):
    """Show warnings raised while a command runs as ``warning: …`` lines on stderr, the values of a parameter an
    option gives said of that option."""
    options = {param.name: param.opts[0] for param in getattr(command, "params", []) if param.opts}

    def show(message, category, filename, lineno, file=None, line=None):
        text = str(message)
        match = _VALUES_WARNING.match(text)
        if match and match["name"] in options:
            text = f"the {match['name']} columns ({options[match['name']]}) " + text[match.end():]
        typer.echo(f"warning: {_one_line(text)}", err=True)

    with warnings.catch_warnings():
        warnings.simplefilter("default")
        # (a file another part of the process left to the garbage collector is nothing the user can act on)
        warnings.simplefilter("ignore", ResourceWarning)
        warnings.showwarning = show
        yield


def _escape_help(command) -> None:
    """Escape ``[`` in help texts so that rich shows "[default: 3]" and "geogait[dask]" as written; a command's
    paragraphs each on one line, wrapped to the terminal."""
    from rich.markup import escape

    if getattr(command, "_geogait_escaped", False):
        return
    command._geogait_escaped = True
    if command.help:  # (one line per paragraph: rich keeps the docstring's line breaks after the first paragraph)
        command.help = "\n\n".join(" ".join(part.split()) for part in inspect.cleandoc(command.help).split("\n\n"))
    for param in getattr(command, "params", []):
        if getattr(param, "help", None):
            param.help = escape(param.help)
    for child in getattr(command, "commands", {}).values():
        _escape_help(child)


_NON_FINITE = {"nan", "inf", "infinity"}


def _refuse_non_finite(group, args) -> None:
    """Refuse nan or ±inf given to a number option with a range, naming the option: the range check
    itself would answer nan with the bound it happens to compare first."""
    command, rest = _command_of(group, args)
    ranged = {opt: param for param in getattr(command, "params", [])
              if getattr(param, "min", None) is not None or getattr(param, "max", None) is not None
              for opt in param.opts}
    for position, token in enumerate(rest):
        name, equals, value = token.partition("=")
        if not equals:
            value = rest[position + 1] if position + 1 < len(rest) else ""
        if name in ranged and value.strip().lower().lstrip("+-") in _NON_FINITE:
            param = ranged[name]
            bounds = " and ".join(f"{sign} {bound:g}" for sign, bound in (("≥", param.min), ("≤", param.max))
                                  if bound is not None)
            raise GeogaitError(f"{name} must be a finite number {bounds}; got {value}.")


class _HelpFromLibrary(TyperCommand):
    """A command whose option help texts name the library's values as ``{placeholders}``: filled in when the command
    is parsed (its ``--help`` included), not when :mod:`geogait.cli` is imported, so that ``geogait --help`` imports
    none of the library (its modules import SciPy and pyplot)."""

    values: Callable[[], dict]
    _filled = False

    def parse_args(self, ctx, args):
        if not self._filled:
            values = self.values()
            for param in self.params:
                if getattr(param, "help", None):
                    param.help = param.help.format_map(values)
            self._filled = True
        return super().parse_args(ctx, args)


def help_from(values: Callable[[], dict]) -> type[TyperCommand]:
    """The command class (``@app.command(cls=...)``) that fills ``{name}`` in its option help texts from ``values()``
    when the command runs or shows its help."""
    return type("HelpFromLibrary", (_HelpFromLibrary,), {"values": staticmethod(values)})


class Terminated(KeyboardInterrupt):
    """SIGINT or SIGTERM, raised where the program is: every ``finally`` and atomic write cleans up."""


_RECEIVED: list[str] = []  # the signals that ended the command


def _interrupt(signum, frame):
    _RECEIVED.append(signal.Signals(signum).name)
    signal.signal(signum, signal.SIG_DFL if signum == signal.SIGTERM else signal.default_int_handler)
    raise Terminated()  # a second signal during the clean-up ends the process at once


@contextmanager
def _signals_as_interrupts():
    """Handle SIGTERM like SIGINT while a command runs (where nobody else handles them); note which came."""
    _RECEIVED.clear()
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    defaults = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: signal.SIG_DFL}
    mine = [signum for signum, default in defaults.items() if signal.getsignal(signum) is default]
    for signum in mine:
        signal.signal(signum, _interrupt)
    try:
        yield
    finally:
        for signum in mine:
            signal.signal(signum, defaults[signum])


def signalled() -> bool:
    """Whether Ctrl-C or SIGTERM came while the command ran (whatever error it then ended in: a driver killed by
    the same Ctrl-C, say)."""
    return bool(_RECEIVED)


def _exit_after_signal(code: int):
    """``sys.exit(code)`` after Ctrl-C or SIGTERM, once every file is written and closed, without the interpreter's
    last full garbage collections: they walk every object SciPy, pandas and matplotlib made (0.25 s on an idle
    machine, 1.4–1.9 s on a loaded 2-core one, more than the 2 s a signal may take), for memory the system takes
    back anyway. Frozen at exit (an atexit handler: an in-process caller that catches the SystemExit keeps
    collecting); the atexit handlers, the flushing of stdout and stderr and every release by reference count still
    run."""
    import atexit
    import gc

    atexit.register(gc.freeze)
    sys.exit(code)


def _interrupted_line() -> str:
    name = _RECEIVED[0] if _RECEIVED else "SIGINT"
    return f"error: {'terminated' if name == 'SIGTERM' else 'interrupted'} ({name}); files already written are complete"


class GeogaitGroup(TyperGroup):
    """The click group of ``geogait``: turns every failure into ``error: …`` and exit code 1."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        _escape_help(self)
        args = sys.argv[1:] if args is None else list(args)
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            with _warnings_as_lines(_command_of(self, args)[0]), _signals_as_interrupts():
                _refuse_non_finite(self, args)
                code = super().main(args, prog_name, complete_var, False, **extra)
        except KeyboardInterrupt:
            typer.echo(_interrupted_line(), err=True)
            _exit_after_signal(1)
        except typer.Abort:
            typer.echo("error: aborted", err=True)
            sys.exit(1)
        except Exception as error:  # the one place every failure is reported
            if type(error).__name__ == "NoArgsIsHelpError":  # `geogait` or `geogait figure` alone: the help
                error.show()
                sys.exit(0)
            if os.environ.get("GEOGAIT_TRACEBACK") and not isinstance(error, TyperException):
                raise
            typer.echo(f"error: {error_message(error, *_command_of(self, args))}", err=True)
            sys.exit(1)
        if code == 130 and _RECEIVED:  # typer turns an interrupt into exit code 130
            typer.echo(_interrupted_line(), err=True)
            _exit_after_signal(1)
        if code in (128 + signal.SIGINT, 128 + signal.SIGTERM):  # (`stream` saved what it learned and tells why)
            _exit_after_signal(code)
        sys.exit(code if isinstance(code, int) else 0)


app = typer.Typer(
    name="geogait",
    help="Adaptive, data-driven gait modeling and in-situ gait optimisation of principally kinematic locomotors."
         "\n\nWords the commands use: r is the shape (joint angles), ξ the body velocity, a gait a periodic path "
         "of r; Γ scores a model's prediction of ξ: 1 − its error / the error of the phase average (1 exact, 0 no "
         "better).",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
    cls=GeogaitGroup,
)
figure_app = typer.Typer(help="Reproduce the paper's figures.", no_args_is_help=True)
app.add_typer(figure_app, name="figure")


def _print_version(value: bool) -> None:
    if value:
        from .. import __version__
        typer.echo(f"geogait {__version__}")
        raise typer.Exit()


@app.callback()
def _options(version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                          help="Print geogait's version and exit.")) -> None:
    """Adaptive, data-driven gait modeling and in-situ gait optimisation of principally kinematic locomotors."""
