"""The command line of the design link: `fvtree run --bridge/--cell-name/--coordinated`,
`fvtree coordinate` (the authority over a design several cells build) and `fvtree design`
(convert a design between node-link and COMPAS JSON). COMPAS is imported only when used."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from assembly.cli.args import POSITIVE, Subparsers
from fvfiles.errors import FvtreeError


def add_link_options(run: argparse.ArgumentParser) -> None:
    """The options of `fvtree run` that link the run's design bridge to a broker."""
    run.add_argument("--bridge", default=None, metavar="mqtt[s]://HOST:PORT",
                     help="also publish the design live over MQTT (compas_eve) and take design updates; the "
                          "as-built file stays the record")
    run.add_argument("--cell-name", default=None, metavar="NAME",
                     help="with --bridge: the topic level of this cell, fvtree/NAME/... (default: the tree's name)")
    run.add_argument("--coordinated", action="store_true",
                     help="with --bridge: take each element from the design's coordinator (fvtree coordinate), "
                          "sharing the design with other cells")
    add_security_options(run)
    run.add_argument("--unsigned", action="store_true",
                     help="with --coordinated: take part without a signing secret (any client on the broker could "
                          "pass for this cell or its coordinator: a private broker only)")
    run.add_argument("--link-lost-after", type=POSITIVE, default=10.0, metavar="SECONDS",
                     help="with --coordinated: a link to the broker lost this long stops the run (FAULT; default: 10)")


def add_security_options(p: argparse.ArgumentParser) -> None:
    """How a link logs in to the broker and speaks TLS (never a user or password in the URL)."""
    p.add_argument("--credentials", default=None, metavar="FILE",
                   help="JSON file (mode 600) with username, password, TLS files and signing secret(s) (default: "
                        "FVTREE_MQTT_USERNAME, FVTREE_MQTT_PASSWORD, FVTREE_LINK_SECRET from the environment)")
    p.add_argument("--tls-ca", default=None, metavar="FILE", help="with mqtts://: the CA certificate to trust")
    p.add_argument("--tls-cert", default=None, metavar="FILE", help="with mqtts://: this client's certificate")
    p.add_argument("--tls-key", default=None, metavar="FILE", help="with mqtts://: this client's private key")


def add_commands(sub: Subparsers) -> None:
    """`fvtree coordinate` and `fvtree design`."""
    c = sub.add_parser("coordinate", help="hand out the elements of a design to several cells over MQTT")
    c.add_argument("design", help="design file (node-link JSON)")
    c.add_argument("--broker", required=True, metavar="mqtt[s]://HOST:PORT")
    add_security_options(c)
    c.add_argument("--lease", type=float, default=10.0, metavar="SECONDS",
                   help="a claim a cell stops renewing expires after this long (default: 10)")
    c.add_argument("--state", default=None, metavar="FILE",
                   help="save the coordinated model here after every change, and resume from it (default: "
                        "DESIGN's name + .coordinated.json in the current directory)")
    c.add_argument("--until-done", action="store_true", help="exit once every element is placed")
    c.add_argument("--unsigned", action="store_true",
                   help="run without the cells' signing secrets (any client on the broker could pass for a cell: "
                        "a private broker only)")
    c.set_defaults(func=cmd_coordinate)

    d = sub.add_parser("design", help="convert a design between node-link JSON and COMPAS JSON")
    d.add_argument("direction", choices=("to-compas", "from-compas"))
    d.add_argument("source")
    d.add_argument("target")
    d.set_defaults(func=cmd_design)


def cmd_coordinate(args) -> int:
    from assembly.design.link.coordinator import Coordinator, load_state
    from assembly.design.link.security import LinkSecurity

    state = Path(args.state or f"{Path(args.design).stem}.coordinated.json")
    security = LinkSecurity.load(args.credentials, ca=args.tls_ca, cert=args.tls_cert, key=args.tls_key)
    if not security.cells and not args.unsigned:
        raise FvtreeError("no signing secrets of the cells: any client on the broker could claim elements and "
                          "report placements in a cell's name", args.credentials or "--credentials",
                          hint="give a credentials file with 'cells' (examples/secure_broker/make_lab.sh makes one), "
                               "or --unsigned on a private broker")
    coordinator = Coordinator(load_state(Path(args.design), state), args.broker, args.lease, state,
                              security=security)  # LinkError (exit 2) when the broker refuses or is down
    signed = f"requests signed by {len(security.cells)} cells" if security.cells else "requests NOT signed"
    print(f"coordinating {coordinator.name} on {args.broker} (claims on {coordinator.topics.claims}, {signed}, "
          f"state in {state})", file=sys.stderr)
    seen = 0

    def print_new() -> None:
        """Print the log entries not printed yet (the coordinator's thread appends meanwhile: count
        what was printed, not the log's length after)."""
        nonlocal seen
        new = coordinator.log[seen:]
        seen += len(new)
        for entry in new:
            print(json.dumps(entry), flush=True)

    coordinator.start()
    try:
        while not (args.until_done and coordinator.done()):
            time.sleep(0.2)
            print_new()
    except KeyboardInterrupt:
        pass
    finally:
        coordinator.stop()
    print_new()
    return 0


def cmd_design(args) -> int:
    from assembly.design.link.compas_data import load_compas, save_compas
    from assembly.design.model import DesignModel
    from fvfiles.json_files import atomic_write_json

    if args.direction == "to-compas":
        save_compas(DesignModel.load(args.source), args.target)
    else:
        atomic_write_json(Path(args.target), load_compas(args.source).to_data())
    print(f"wrote {args.target}")
    return 0
