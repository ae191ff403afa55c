"""The ``hgo`` command: ``hgo run <overrides>``, ``hgo reproduce [paper ...]``, ``hgo list``.

Imports are lazy: ``hgo --help`` loads neither Hydra nor numba.
"""

from __future__ import annotations

import argparse
import gc
import os
import signal
import sys


def user_modules_importable() -> None:
    """Modules in the current directory importable by ``_target_`` (``vdp.make_vdp`` with
    ``vdp.py`` here), first on the path as ``python -m`` puts them: the ``hgo`` console
    script's own ``sys.path[0]`` is its ``bin/`` folder instead."""
    cwd = os.getcwd()
    if cwd not in sys.path:
        sys.path.insert(0, cwd)


def run_app(args: list[str], prog: str = "hgo run") -> int:
    """``hgo run``: the Hydra application (:mod:`hgo.cli.app`) on ``args``; ``prog`` is the
    command name Hydra and ``run.json`` see (``experiments/run.py`` passes its own)."""
    user_modules_importable()
    from hgo.running.figure_worker import discard_prestarted, prestart

    if single_run(args):  # its figure process prepares while this one imports and runs
        prestart()
    try:
        return _run_hydra_app(args, prog)
    finally:
        discard_prestarted()


def _run_hydra_app(args: list[str], prog: str) -> int:
    from hgo.core.memory import collection_paused

    with collection_paused():  # imports make ~1M lasting objects, no garbage: ~0.07 s
        from hgo.cli.app import cli_main
    gc.freeze()  # (later full passes skip them too)

    from hgo.core.config import check_override_lengths
    from hgo.core.errors import ConfigError

    try:
        check_override_lengths(args)
        check_one_mode(args)
    except ConfigError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    sys.argv = [prog, *args]
    # SIGTERM (``kill``, a scheduler's time limit) ends a run as Ctrl-C does: the kernel
    # stops within a step, outputs up to then are written and marked interrupted, exit 130
    # (by default it ended the process at once, marking nothing). Python's own Ctrl-C
    # handler: the engine watches the signals that have it (hgo.engine.interrupt).
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    if single_run(args):  # one composition of the config, not Hydra's two
        from hgo.cli.compose_once import composed_once

        with composed_once():
            cli_main()
    else:
        cli_main()
    return 0


def single_run(args: list[str]) -> bool:
    """Whether the command line asks for one run: no sweep (``-m``, ``hydra.mode``), none
    of Hydra's other modes, no help. (A preset may still make it a sweep: the run then
    discards the figure process it did not need.)"""
    keys = {a.partition("=")[0] for a in args}
    return not (keys & (set(MODES) | {"-h", "--help", "--hydra-help", "hydra.mode"}))


# Hydra's modes, of which a command line takes one (Hydra itself raises a ValueError)
MODES = {"-m": "--multirun", "--multirun": "--multirun", "-r": "--run", "--run": "--run",
         "-c": "--cfg", "--cfg": "--cfg", "-i": "--info", "--info": "--info",
         "-sc": "--shell-completion", "--shell-completion": "--shell-completion"}


def check_one_mode(args: list[str]) -> None:
    """Refuse two of Hydra's modes at once (``-m ... --cfg job``) in one line."""
    from hgo.core.errors import ConfigError

    given = sorted({MODES[a.partition("=")[0]] for a in args if a.partition("=")[0] in MODES})
    if len(given) > 1:
        raise ConfigError(" and ".join(given), "one mode at a time",
                          ", ".join(sorted(set(MODES.values()))))


def _reproduce(args: list[str]) -> int:
    from hgo.reproduce.run import main

    return main(args)


def _list(args: list[str]) -> int:
    from hgo.cli.catalog import main

    return main(args)


def _observability(args: list[str]) -> int:
    user_modules_importable()  # (a Python model named by _target_ in the current directory)
    from hgo.cli.observability import main

    return main(args)


def _view(args: list[str]) -> int:
    from hgo.cli.view import main

    return main(args)


def _runs_command(name: str):
    def command(args: list[str]) -> int:
        from hgo.cli import runs as runs_cli

        return getattr(runs_cli, name)(args)

    return command


COMMANDS = {
    "run": (run_app, "run an experiment: hgo run experiment=sp_fig1 [-m for sweeps] "
                  "[--config-dir DIR: your groups and presets] (Hydra overrides; "
                  "hgo run --help lists the groups)"),
    "reproduce": (_reproduce, "run every figure and claim of the papers and write a report "
                              "(hgo reproduce --help)"),
    "list": (_list, "the experiment presets with their descriptions, and each group's options "
                    "(--config-dir DIR: yours too)"),
    "runs": (_runs_command("runs"), "every run under outputs/ as one table (--where, --metrics, "
                                    "--compare A B)"),
    "show": (_runs_command("show"), "one run: status, provenance, config, metrics"),
    "export": (_runs_command("export"), "a recording as CSV or Parquet (--format csv|parquet)"),
    "observability": (_observability, "Phi, dPhi/dx, its singular set and phi0 of a plant given "
                                      "by its equations: hgo observability plant=lotka_volterra"),
    "view": (_view, "open runs (a sweep directory: all its jobs) in the Rerun viewer, each its "
                    "own recording (--web: serve to a browser and print the ports to forward)"),
}


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(
        prog="hgo", description="hgo: high-gain observer experiments.",
        epilog="\n".join(f"  {name:10s} {text}" for name, (_, text) in COMMANDS.items()),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("command", choices=COMMANDS, metavar="command",
                        help="one of: " + ", ".join(COMMANDS))
    if not argv or argv[0] in ("-h", "--help"):
        parser.print_help()
        return 0
    if argv[0] not in COMMANDS:
        parser.print_usage(sys.stderr)
        print(f"hgo: error: unknown command '{argv[0]}' (allowed: {', '.join(COMMANDS)})",
              file=sys.stderr)
        return 2
    try:
        return COMMANDS[argv[0]][0](argv[1:])
    except BrokenPipeError:  # `hgo runs | head`: the reader left, nothing to report
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    raise SystemExit(main())
