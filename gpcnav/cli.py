"""gpcnav: one command, one subcommand per job. README.md says how to start; docs/ documents
the model, the assumptions, scenarios and suites, the solvers, the network, faults and the
check layer, real pedestrians, buildings, and the architecture."""
from __future__ import annotations

import argparse
import errno
import importlib
import os
import signal
import sys
import threading

from .errors import ControllerError, UsageError

# subcommand name -> module under gpcnav.commands with add_arguments(parser) and run(args)
COMMANDS = {
    "simulate": "Run one closed-loop episode.",
    "evaluate": "Run many episodes and write aggregate metrics.",
    "compare": "Run several controllers on the same episodes; table and figure.",
    "dataset": "Label situations with the GPC (resumable).",
    "train": "Train the network on a dataset.",
    "export": "Export a trained network to ONNX.",
    "bench": "The solver benchmark.",
    "reproduce": "The paper end to end.",
    "import-tracks": "Scenario files from a recording of pedestrians (ETH/UCY format).",
}


RESUMABLE = ("evaluate", "compare", "dataset", "reproduce")
"""The subcommands whose finished work survives an interruption (docs/evaluation.md; reproduce:
its finished stages)."""


class DefaultsFormatter(argparse.HelpFormatter):
    """Every option's help ends with its default (argparse's ArgumentDefaultsHelpFormatter,
    which would repeat one the help already names, and print ``None`` and ``False``)."""

    def _get_help_string(self, action):
        text = action.help or ""
        if (not action.option_strings or action.default is argparse.SUPPRESS or action.required
                or "default" in text.lower() or "%(default)" in text):
            return text
        if action.default is None or action.default is False:
            shown = "off" if action.default is False or action.nargs == 0 else "none"
        else:
            shown = "%(default)s"
        return f"{text} (default: {shown})" if text else f"default: {shown}"


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse prints usage too)
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="gpcnav", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, help_text in COMMANDS.items():
        module = importlib.import_module(f"gpcnav.commands.{name.replace('-', '_')}")
        p = sub.add_parser(name, help=help_text, description=(module.__doc__ or help_text).strip(),
                           formatter_class=DefaultsFormatter)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM (``timeout``, a job scheduler, ``kill``), raised in the main thread so that the
    command stops as on Ctrl-C: its ``finally`` blocks run (a compile's temporary folder is
    removed, finished episodes are kept) and it says so in one line."""


_TERMINATING = threading.Event()
_STOPPED = threading.Event()
_DEPTH = 0
"""How many :func:`main` calls are running: more than one inside ``reproduce``, whose stages are
commands run through ``main()``; a stop is the outermost call's to handle and say."""
_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _stop(signum, frame):
    """SIGINT's and SIGTERM's handler: from now on nothing more is written
    (:func:`casadi_gpc.io.request_stop`), and :class:`KeyboardInterrupt` (SIGINT) or
    :class:`Terminated` (SIGTERM) is raised in the main thread. An exception raised while
    CasADi's C++ code calls back into Python (its output, its solvers' interrupt check) is lost
    there, or taken for a failed solve, and the command ran on to its end with that episode's
    numbers changed (measured: a SIGTERM during a compile's code generation; a Ctrl-C during a
    solve, 1 run in 5 with one worker), so the signal is sent again every second until
    :func:`main` has caught one, and what finishes meanwhile is not kept."""
    from casadi_gpc.io import request_stop
    request_stop()
    if _STOPPED.is_set():  # main() is saying so already: another signal (``timeout`` sends SIGTERM to the
        return             # process and then to its group; our own resend) would break off its one line
    if not _TERMINATING.is_set():
        _TERMINATING.set()
        threading.Thread(target=_repeat, args=(signum,), daemon=True).start()
    raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def _repeat(signum):
    while not _STOPPED.wait(1.0):
        os.kill(os.getpid(), signum)


def _stopped(args, exc: BaseException) -> int:
    """The stop's one line and exit status (``exc``: the exception it came as); inside another
    command (``reproduce``'s stages) ``exc`` goes on to it. (Until 2026-12-01 a stage said its own
    stop, then ``reproduce`` said "error: stage command failed (exit 130)" and exited 2; and once
    a stage had run, a Ctrl-C in ``reproduce``'s own work was taken and not raised.)"""
    if _DEPTH > 1:
        raise exc
    _STOPPED.set()  # first: a signal from now on is not raised (_stop)
    terminated = _terminated(exc)
    resumes = "; what finished is kept: the same command resumes" if args.command in RESUMABLE else ""
    if args.command == "dataset" and getattr(args, "dagger", None) is not None:
        resumes = "; an on-policy round is kept only whole: the same command runs it again"
    print(f"gpcnav {args.command}: {'terminated' if terminated else 'interrupted'}{resumes}", file=sys.stderr)
    return 143 if terminated else 130


def main(argv=None) -> int:
    global _DEPTH
    args = build_parser().parse_args(argv)
    from scenarios import ScenarioError
    from casadi_gpc.io import clear_stop, stop_requested
    from casadi_gpc.pool import WorkersDied, abandon_live_pools
    from casadi_gpc.types import ProtocolError
    outermost = _DEPTH == 0
    previous = {}
    if outermost:
        _TERMINATING.clear()
        _STOPPED.clear()
        clear_stop()
        if threading.current_thread() is threading.main_thread():
            previous = {sig: signal.signal(sig, _stop) for sig in _SIGNALS}
    _DEPTH += 1
    try:
        try:
            return int(args._run(args) or 0)
        except (UsageError, ScenarioError, ProtocolError, ControllerError) as exc:
            if stop_requested():
                return _stopped(args, exc)
            kept = "; what finished before is kept" if isinstance(exc, ControllerError) and args.command in RESUMABLE \
                else ""
            print(f"gpcnav {args.command}: error: {exc}{kept}", file=sys.stderr)
            return 2
        except KeyboardInterrupt as exc:
            return _stopped(args, exc)
        except WorkersDied as exc:
            if stop_requested():
                return _stopped(args, exc)
            kept = "; what finished is kept: the same command resumes" if args.command in RESUMABLE else ""
            print(f"gpcnav {args.command}: error: {exc}{kept}", file=sys.stderr)
            return 1
        except OSError as exc:
            if stop_requested():
                return _stopped(args, exc)
            if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
                raise
            # a full disk: what finished before is kept (every file is written whole or not at all)
            print(f"gpcnav {args.command}: error: {exc.strerror}: {exc.filename or 'a file'}", file=sys.stderr)
            return 1
        except Exception as exc:
            # a stop raised inside a library's call back into Python comes out as its error (numpy's,
            # CasADi's SystemError "returned a result with an exception set"): a stop all the same
            if stop_requested():
                return _stopped(args, exc)
            raise
    except KeyboardInterrupt as exc:
        # a second signal that landed while the first was being handled, before _stopped() (a
        # `timeout` sends SIGTERM twice, to the process and to its group: a traceback of two
        # Terminated until 2026-11-30); the chain of exceptions holds the first
        return _stopped(args, exc)
    finally:
        _DEPTH -= 1
        if outermost:
            _STOPPED.set()
            clear_stop()
            abandon_live_pools()  # (a stop before a pool's results were asked for: its workers, ended)
        for sig, handler in previous.items():  # (stopping: the repeated signals are not the next command's)
            signal.signal(sig, signal.SIG_IGN if _TERMINATING.is_set() else handler)


def _terminated(exc: BaseException) -> bool:
    """Whether a stop was SIGTERM's: ``exc`` or what it came from is :class:`Terminated`."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, Terminated):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


if __name__ == "__main__":
    raise SystemExit(main())
