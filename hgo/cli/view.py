"""``hgo view RUN...``: open runs in the Rerun viewer, each as its own recording.

A RUN is a run directory (its ``recording.rrd``), a sweep or ensemble directory (every
``recording.rrd`` below it: all its jobs), or an ``.rrd`` file. Every run was written with a
recording id of its own (:func:`hgo.running.runner.recording_id`), so the viewer lists them side by
side and a view can show one series of several runs together.

``--web`` serves them to a browser instead (a headless machine): Rerun's web viewer is a page
on the HTTP port (``--web-port``, 9090) that then fetches the recordings from Rerun's gRPC
proxy on a second port (``--grpc-port``, 9876) — the page's URL names that port. From your
own computer both ports must reach the machine, e.g.
``ssh -L 9090:localhost:9090 -L 9876:localhost:9876 <machine>``; the command prints exactly
this line and the URL to open.
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
from pathlib import Path
from urllib.parse import quote

RECORDING = "recording.rrd"
WEB_PORT = 9090  # Rerun's default for the web viewer's page (HTTP)
GRPC_PORT = 9876  # Rerun's default for its gRPC proxy, which the page connects to


class NoRecording(ValueError):
    """A RUN argument that holds no recording, or no viewer to show it."""


def recordings(run: Path) -> list[Path]:
    """The ``.rrd`` files of one RUN argument (see the module doc), in path order."""
    if run.is_file() and run.suffix == ".rrd":
        return [run]
    if (run / RECORDING).is_file():
        return [run / RECORDING]
    if run.is_dir():
        found = sorted(run.rglob(RECORDING), key=lambda p: [_natural(s) for s in p.parts])
        if found:
            return found
        raise NoRecording(f"{run}: no {RECORDING} in this directory or below it "
                          "(recording.mode=off, or not a run directory)")
    raise NoRecording(f"{run}: no such run directory or .rrd file")


def _natural(part: str) -> tuple:
    """``job10`` after ``job9``."""
    digits = part.lstrip("abcdefghijklmnopqrstuvwxyz_-")
    return (part[: len(part) - len(digits)], int(digits)) if digits.isdigit() else (part, -1)


RRD_MAGIC = b"RRF"  # the first bytes of every Rerun recording file


def is_recording_file(path: Path) -> bool:
    """Whether ``path`` may be a Rerun recording: it starts as one, or is empty (left to
    the viewer); a foreign or overwritten file does not."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(len(RRD_MAGIC))
    except OSError:
        return False
    return head in (RRD_MAGIC, b"")


def _damage(path: Path) -> str:
    """The one line of a recording whose size differs from the one its run recorded
    (:mod:`hgo.outputs.integrity`; the viewer reads it, not hgo: no hash), else ""."""
    from hgo.outputs.integrity import Damaged, check_run

    try:
        check_run(path.parent, hashed=False, only={path.name})
    except Damaged as err:
        return str(err)
    return ""


def all_recordings(runs: list[Path], skipped: list[str] | None = None) -> list[Path]:
    """The recordings of every RUN, each file once, in the order given; a file that is not
    a Rerun recording is left out when ``skipped`` is given (its one line appended there),
    and then none left raises :class:`NoRecording`."""
    files: list[Path] = []
    for run in runs:
        for path in recordings(run):
            if path in files:
                continue
            if skipped is None:
                files.append(path)
            elif not is_recording_file(path):
                skipped.append(f"{path}: not a Rerun recording (unreadable or another file)")
            elif damage := _damage(path):
                skipped.append(damage)
            else:
                files.append(path)
    if not files:
        raise NoRecording("no readable recording among " + ", ".join(map(str, runs)))
    return files


def rerun_binary() -> str:
    """The ``rerun`` executable of rerun-sdk (what ``python -m rerun`` starts as a child;
    run directly, Ctrl-C and SIGTERM reach the viewer itself)."""
    import importlib.util

    if "RERUN_CLI_PATH" in os.environ:  # rerun-sdk's own override
        return os.environ["RERUN_CLI_PATH"]
    spec = importlib.util.find_spec("rerun_cli")
    folder = Path(next(iter(spec.submodule_search_locations))) if spec else None
    binary = folder / ("rerun.exe" if sys.platform == "win32" else "rerun") if folder else None
    if binary is None or not binary.is_file():
        raise NoRecording("the Rerun viewer is not installed (rerun-sdk's rerun_cli/rerun)")
    return str(binary)


def viewer_command(files: list[Path], web: bool = False, web_port: int = WEB_PORT,
                   grpc_port: int = GRPC_PORT, bind: str = "127.0.0.1") -> list[str]:
    """The Rerun command: the native viewer on ``files``, or (``web``) the web viewer's
    page on ``web_port`` and the gRPC proxy serving ``files`` on ``grpc_port``."""
    command = [rerun_binary()]
    if web:
        command += ["--serve-web", "--web-viewer-port", str(web_port), "--port", str(grpc_port),
                    "--bind", bind]
    return command + [str(f) for f in files]


def web_instructions(web_port: int, grpc_port: int) -> list[str]:
    """What to forward and what to open, for a browser on another computer."""
    proxy = quote(f"rerun+http://localhost:{grpc_port}/proxy", safe="")
    return [
        f"forward ports {web_port} (the web viewer's page, HTTP) and {grpc_port} (Rerun's gRPC "
        "proxy, which the page connects to for the recordings):",
        f"  ssh -L {web_port}:localhost:{web_port} -L {grpc_port}:localhost:{grpc_port} "
        "<this machine>",
        f"then open  http://localhost:{web_port}/?url={proxy}",
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="hgo view", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", type=Path, metavar="RUN",
                        help="run directory, sweep directory or .rrd file")
    parser.add_argument("--web", action="store_true",
                        help="serve to a browser (headless machine) instead of a window")
    parser.add_argument("--web-port", type=int, default=WEB_PORT,
                        help=f"HTTP port of the web viewer's page (default {WEB_PORT})")
    parser.add_argument("--grpc-port", type=int, default=GRPC_PORT,
                        help=f"port of the gRPC proxy the page reads from (default {GRPC_PORT})")
    parser.add_argument("--bind", default="127.0.0.1",
                        help="address to listen on with --web (default 127.0.0.1: reach it "
                             "through ssh -L; 0.0.0.0 opens it to the network)")
    parser.add_argument("--print-command", action="store_true",
                        help="print the Rerun command instead of running it")
    args = parser.parse_args(argv)
    skipped: list[str] = []
    try:
        files = all_recordings(args.runs, skipped)
        command = viewer_command(files, args.web, args.web_port, args.grpc_port, args.bind)
    except NoRecording as err:
        for line in skipped:
            print(f"skipped: {line}", file=sys.stderr)
        print(f"error: {err}", file=sys.stderr)
        return 2
    for line in skipped:  # one line each; the others are shown
        print(f"skipped: {line}", file=sys.stderr)
    print(f"view: {len(files)} recording(s), each its own recording in the viewer")
    if args.web:
        print("\n".join(web_instructions(args.web_port, args.grpc_port)))
    if args.print_command:
        print(shlex.join(command))  # (a path with a space or a quote pastes as one word)
        return 0
    sys.stdout.flush()
    os.execv(command[0], command)  # this process becomes the viewer
    return 0  # (not reached)
