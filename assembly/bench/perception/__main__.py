"""`python -m assembly.bench.perception --out DIR [--quick]`."""

from assembly.bench import script
from assembly.bench.perception import run

raise SystemExit(script("python -m assembly.bench.perception", run, "bench/perception",
                        "short sequences (smoke test, < 60 s)", __doc__))
