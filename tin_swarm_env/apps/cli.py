"""The ``tin-swarm`` command line.

    tin-swarm [--debug] COMMAND ...      COMMAND: run, scenarios, explore, train, eval, build-tin
    tin-swarm COMMAND --help             every option of COMMAND, what it accepts and its default

Every subcommand's options are the fields of one ``Args`` dataclass in the module that does the
work (:data:`COMMANDS`): ``run`` (:mod:`~.run`), ``scenarios`` (:mod:`~.scenarios`), ``explore``
(:mod:`~.explorer`), ``train`` (:mod:`~.train`, over :mod:`tin_swarm_env.training`), ``eval`` (:mod:`~.evaluate`), ``build-tin``
(:mod:`~.build_tin`). A field's help text is its ``--help`` line and its range or choices are
checked once, when the ``Args`` is built (:mod:`~.args`), so a bad value stops with one line
naming the option before any work starts.

Bad input never ends in a traceback: every option and output path is checked before the work
starts, and any error (a :class:`~tin_swarm_env.errors.TinSwarmError`, an ``OSError`` such as a
full or read-only disk) is one line on stderr with exit status 2 (1 for an unexpected error);
Ctrl-C prints "interrupted" and exits with 130. ``--debug`` (or ``TIN_SWARM_DEBUG=1``) re-raises
instead, with the traceback. Policies: ``apf``/``random`` (any case) or a pickle-free policy
directory; an SB3 ``.zip`` is a pickle (loading it can run code) and needs ``--trust-pickle``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import sys
from dataclasses import dataclass, field

from ..errors import ArgumentError, TinSwarmError
from .args import add_dataclass_args, dataclass_from_namespace, option_name

__all__ = ["main", "build_parser", "COMMANDS"]


@dataclass(frozen=True)
class Command:
    """One subcommand: its ``Args`` dataclass and the function that runs it (``"module:name"``,
    relative to this package), the one-line help and how the fields become arguments
    (``positional`` fields, ``rename`` field -> option name, ``cli`` more ``add_argument`` keywords)."""

    args: str
    run: str
    help: str
    positional: tuple = ()
    rename: dict = field(default_factory=dict)
    cli: dict = field(default_factory=dict)

    def load(self, what: str):
        mod, _, name = what.partition(":")
        return getattr(importlib.import_module(f".{mod}", __package__), name)


COMMANDS = {
    "run": Command("run:Args", "run:run", "run a swarm on a scenario and report each episode (optionally a GIF/MP4)",
                   positional=("scenario",)),
    "scenarios": Command("scenarios:Args", "scenarios:scenarios", "list the built-in scenarios, or copy one to "
                         "start from"),
    "explore": Command("explorer:Args", "explorer:explore", "the field explorer (a window, or --png OUT.png "
                       "headless)", positional=("scenario",)),
    "train": Command("train:Args", "train:train_command", "train a shared policy with PPO, optionally after imitation of "
                     "APF, and export it as a policy file (needs the [train] extra)", positional=("scenario",), rename={"total_timesteps": "timesteps"}),
    "eval": Command("evaluate:Args", "cli:_eval", "random, APF and saved policies on the same scenarios and seeds "
                    "(or --suite standard: the standard suite's leaderboard)",
                    positional=("scenarios",), rename={"models": "model"},
                    cli={"scenarios": {"nargs": "*"}, "models": {"action": "append", "metavar": "MODEL"}}),
    "build-tin": Command("build_tin:Args", "build_tin:build_tin", "reduce a DEM to a TIN and write it (.tin/.txt "
                         "or .npz)", positional=("dem",)),
}


def _eval(a) -> int:
    from .evaluate import evaluate
    from .suite import run_suite

    (run_suite if a.suite else evaluate)(a)
    return 0


class _Formatter(argparse.ArgumentDefaultsHelpFormatter):
    """Help with every option's default shown (``(default: ...)``), empty defaults left out."""

    def _get_help_string(self, action):
        if action.default is False and action.type is not None and action.option_strings:  # a true/false option
            return super()._get_help_string(action)
        if action.default is None or action.default is False or action.default in ([], ""):
            return action.help
        return super()._get_help_string(action)


def _cli_names(msg: str, rename: dict) -> str:
    """``msg`` with each renamed field's option (``--total-timesteps``) written as the subcommand
    spells it (``--timesteps``)."""
    for f, new in rename.items():
        msg = re.sub(rf"(?<![\w-]){re.escape(option_name(f))}(?![\w-])", option_name(new), msg)
    return msg


def _runner(cmd: Command):
    """The ``func`` of a parsed subcommand: build its ``Args`` (checked there) and run it; an error
    names the options as this subcommand spells them."""
    def run(ns: argparse.Namespace) -> int:
        try:
            cls = cmd.load(cmd.args)
            a = dataclass_from_namespace(cls, ns)
            return cmd.load(cmd.run)(a)
        except ArgumentError as exc:
            msg = _cli_names(str(exc), cmd.rename)
            if msg == str(exc):
                raise
            raise ArgumentError(msg) from exc
    return run


def build_parser() -> argparse.ArgumentParser:
    """The parser of every subcommand, generated from the ``Args`` dataclasses of :data:`COMMANDS`."""
    from .. import __version__

    p = argparse.ArgumentParser(prog="tin-swarm", description="Robot swarms on TIN terrain.",
                                formatter_class=_Formatter)
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    p.add_argument("--debug", action="store_true",
                   help="show the traceback of an error instead of one line (also: TIN_SWARM_DEBUG=1)")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, cmd in COMMANDS.items():
        cls = cmd.load(cmd.args)
        sp = sub.add_parser(name, help=cmd.help, description=f"{cmd.help[0].upper()}{cmd.help[1:]}.",
                            formatter_class=_Formatter)
        add_dataclass_args(sp, cls, positional=cmd.positional, rename=cmd.rename, cli=cmd.cli)
        sp.set_defaults(func=_runner(cmd))
    return p


def main(argv=None) -> int:
    """Parse ``argv`` and run the subcommand; returns the exit status (0 ok, 2 bad input or an
    OSError, 1 an unexpected error, 130 Ctrl-C), printing one line on stderr for any error."""
    try:
        args = build_parser().parse_args(argv)
    except KeyboardInterrupt:
        print("tin-swarm: interrupted", file=sys.stderr)
        return 130
    debug = args.debug or os.environ.get("TIN_SWARM_DEBUG", "") not in ("", "0")
    real_stdout, real_stderr = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = _PipeSafe(real_stdout), _PipeSafe(real_stderr)
    try:
        return args.func(args)
    except KeyboardInterrupt:
        if debug:
            raise
        print("tin-swarm: interrupted", file=sys.stderr)
        return 130
    except (TinSwarmError, ValueError, OSError) as exc:
        if debug:
            raise
        print(f"tin-swarm: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except Exception as exc:  # a bug or a library's own error: still one line (the traceback with --debug)
        if debug:
            raise
        print(f"tin-swarm: error: {type(exc).__name__}: {_one_line(exc)} (rerun with --debug for the traceback)",
              file=sys.stderr)
        return 1
    finally:
        sys.stdout, sys.stderr = real_stdout, real_stderr


class _PipeSafe:
    """``sys.stdout`` (and ``sys.stderr``) for a command: once its reader has gone (``tin-swarm run | head``: a
    ``BrokenPipeError``), what the command prints is dropped and the command goes on (its files
    are still written whole), with no traceback and no error line; the file descriptor is pointed
    at ``/dev/null`` so that nothing fails at exit either."""

    def __init__(self, stream):
        self._stream, self.broken = stream, False

    def _gone(self):
        self.broken = True
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
            os.close(devnull)
        except (OSError, ValueError, AttributeError):  # a stream without a descriptor (tests)
            pass

    def write(self, s):
        if self.broken:
            return len(s)
        try:
            return self._stream.write(s)
        except BrokenPipeError:
            self._gone()
            return len(s)

    def flush(self):
        if self.broken:
            return
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._gone()

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _one_line(exc: BaseException) -> str:
    """The exception's message on one line (an OSError names its file)."""
    if isinstance(exc, OSError) and exc.filename and exc.strerror:
        msg = f"{exc.filename}: {exc.strerror}"
    else:
        msg = str(exc) or type(exc).__name__
    return " ".join(msg.split())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
