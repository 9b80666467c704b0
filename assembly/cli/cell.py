"""`fvtree check --cell CELL`: connect to each device of a cell and report, moving nothing."""

from __future__ import annotations

from assembly.cli.args import Subparsers
from assembly.cli.exits import EXIT_FAILURE


def add_commands(sub: Subparsers) -> None:
    """`fvtree check`."""
    c = sub.add_parser("check", help="connect to each device of a cell and report, moving nothing")
    c.add_argument("--cell", required=True)
    c.set_defaults(func=cmd_check)


def cmd_check(args) -> int:
    from drivers.check import check_cell

    results = check_cell(args.cell)
    for device, ok, detail in results:
        print(f"{'OK  ' if ok else 'FAIL'} {device}: {detail}")
    return 0 if all(ok for _, ok, _ in results) else EXIT_FAILURE
