"""`python -m assembly.bench.perception --out DIR [--quick]`."""

import argparse
from pathlib import Path

from assembly.bench.perception import run

parser = argparse.ArgumentParser(prog="python -m assembly.bench.perception", description=__doc__)
parser.add_argument("--out", type=Path, default=Path("bench/perception"), help="output directory")
parser.add_argument("--quick", action="store_true", help="short sequences (smoke test, < 60 s)")
args = parser.parse_args()
for path in run(args.out, args.quick):
    print(path)
