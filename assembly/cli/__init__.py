"""`fvtree`: run, validate, show and document behaviour trees of tactile skills."""

from __future__ import annotations

import argparse
import errno
import logging
import os
import signal
import sys

from assembly.cli import bench, cell, design, interop, learning, observe, run, trees
from assembly.cli.exits import EXIT_FAILURE, EXIT_USAGE, report
from fvfiles.errors import DISK_FULL, FvtreeError

__all__ = ["EXIT_FAILURE", "EXIT_USAGE", "main", "parser", "report"]

# The command groups, each a module with add_commands(subparsers), in the order `fvtree --help` lists them.
GROUPS = (run, trees, interop, observe, bench, cell, learning, design)


def parser() -> argparse.ArgumentParser:
    """The `fvtree` argument parser: the global options, then every group's commands."""
    p = argparse.ArgumentParser(prog="fvtree", description=__doc__)
    p.add_argument("--debug", action="store_true", help="show tracebacks and debug logs")
    p.add_argument("--allow-include", action="append", default=[], metavar="DIR",
                   help="let trees include files from DIR too (by default only from the tree's own folder)")
    sub = p.add_subparsers(dest="command", required=True)
    for group in GROUPS:
        group.add_commands(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the command `argv` names (default: the process's arguments); returns the exit code, one line on
    stderr for an error unless --debug."""
    if hasattr(signal, "SIGXFSZ"):  # past a file-size limit (ulimit -f) a write fails with EFBIG, not a kill
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    args = parser().parse_args(argv)
    if args.allow_include:  # read by the tree reader (assembly.language.reader.INCLUDE_PATH), and by workers
        given = [os.path.abspath(d) for d in args.allow_include]
        os.environ["FVTREE_INCLUDE_PATH"] = os.pathsep.join([*given, *filter(None, [os.environ.get("FVTREE_INCLUDE_PATH")])])
    logging.basicConfig(level=logging.DEBUG if args.debug else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return args.func(args)
    except FvtreeError as exc:
        return report(exc)
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM outside a tick loop (which halts the run itself)
        print("interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # last resort: one line unless --debug
        if args.debug:
            raise
        if isinstance(exc, OSError) and exc.filename is not None:  # a path given on the command line
            return report(FvtreeError(exc.strerror or str(exc), str(exc.filename)))
        if isinstance(exc, OSError) and exc.errno in DISK_FULL:  # a write with no name to it: still no traceback
            return report(FvtreeError(f"cannot write: {exc.strerror} ({errno.errorcode[exc.errno]})",
                                      hint="free some disk space (df -h) or raise the file-size limit (ulimit -f)"))
        print(f"error: {type(exc).__name__}: {exc} (rerun with --debug for the traceback)", file=sys.stderr)
        return EXIT_FAILURE


if __name__ == "__main__":
    sys.exit(main())
