"""The commands of the learned tactile models: `fvtree record` (per-tick features and labels of runs),
`fvtree import-log` (BlobMoves logs of other FingerVision software as a recording) and `fvtree train`."""

from __future__ import annotations

from assembly.cli.args import POSITIVE_INT, SEED, Subparsers, add_cell_option, add_perception_option, existing_file
from fvfiles.errors import FvtreeError


def add_commands(sub: Subparsers) -> None:
    """`fvtree record`, `import-log` and `train`."""
    rec = sub.add_parser("record", help="run a tree and record per-tick tactile features and labels")
    rec.add_argument("tree")
    rec.add_argument("--out", required=True, help="recording file to write (.npz)")
    add_cell_option(rec)
    rec.add_argument("--seed", type=SEED, default=0, help="seed of the first run")
    rec.add_argument("--runs", type=POSITIVE_INT, default=1,
                     help="record this many runs (seeds seed, seed+1, ...)")
    rec.add_argument("--randomise", action="store_true",
                     help="on the randomised simulated cell (`world: {randomise: true}`, as `fvtree bench "
                          "robustness` runs it): each run's seed draws its sensor, skin and scene")
    add_perception_option(rec)
    rec.set_defaults(func=cmd_record)

    cal = sub.add_parser("calibrate-sensor", help="measure the fingertips' gains, rest noise and skin lag against known loads "
                                                  "(the press scene's scale) and write a sensor profile a cell "
                                                  "file can name (sensor: {profile: PATH})")
    cal.add_argument("--out", required=True, help="sensor profile to write (.yaml)")
    add_cell_option(cal)
    cal.add_argument("--seed", type=SEED, default=0)
    cal.add_argument("--object", default=None, help="what the pressed stick is made of (wood, glass, rubber, foam, "
                                                    "steel; default the scene's neutral stick)")
    add_perception_option(cal)
    cal.set_defaults(func=cmd_calibrate_sensor)

    il = sub.add_parser("import-log", help="turn BlobMoves marker logs of other FingerVision software (one trial "
                                           "per JSON or YAML file) into a recording for fvtree train")
    il.add_argument("logs", nargs="+", type=existing_file, metavar="LOG")
    il.add_argument("--out", required=True, help="recording file to write (.npz)")
    il.set_defaults(func=cmd_import_log)

    tr = sub.add_parser("train", help="train ForceLearn (force) or StirLearn (stir) on a recording")
    tr.add_argument("kind", choices=("force", "stir"))
    tr.add_argument("data", type=existing_file, nargs="+", help="recordings made by fvtree record (joined)")
    tr.add_argument("--out", required=True, help="model file to write (.npz)")
    tr.add_argument("--seed", type=SEED, default=0)
    tr.add_argument("--test", type=existing_file, default=None, metavar="RECORDING",
                    help="stir: test on every trial of this recording of another session (fvtree record "
                         "--seed N) instead of holding out trials of DATA")
    tr.set_defaults(func=cmd_train)


def cmd_record(args) -> int:
    import tempfile
    from pathlib import Path

    from assembly.bench.robustness import randomised_cell
    from assembly.dataset_recorder import record

    if args.randomise and args.cell != "sim":
        raise FvtreeError(f"--randomise draws the simulated cell (sim); it cannot be combined with --cell {args.cell}")
    with tempfile.TemporaryDirectory() as tmp:
        cell = str(randomised_cell(Path(tmp))) if args.randomise else args.cell
        out = record(args.tree, args.out, cell=cell, seed=args.seed, runs=args.runs, perception=args.perception)
    print(f"wrote {out}")
    return 0


def cmd_calibrate_sensor(args) -> int:
    from assembly.sensor_calibration import run
    from drivers.sim.models.objects import OBJECTS

    if args.object is not None and args.object not in OBJECTS:
        raise FvtreeError(f"--object: no object {args.object!r}; known: {', '.join(sorted(OBJECTS))}")
    path, cal = run(args.out, cell=args.cell, seed=args.seed, perception=args.perception,
                    scene_args={} if args.object is None else {"object": args.object})
    print(f"normal {cal.normal_px_per_n:.4f} px/N, shear {cal.shear_px_per_n:.4f} px/N, rest jitter "
          f"{cal.rest_jitter_px:.4f} px (persistence {cal.jitter_persistence:.2f})")
    if cal.skin is not None:
        creep = (f"creep {cal.skin.creep_share:.1%} over {cal.skin.creep_s:.2g} s" if cal.skin.creep_share is not None
                 and cal.skin.creep_s is not None else "no creep told apart from noise")
        print(f"skin lag {cal.skin.lag_s:.3f} s, hysteresis {cal.skin.hysteresis:.2f}, {creep}")
    print(f"wrote {path}")
    return 0


def cmd_import_log(args) -> int:
    from perception.learning.blobmoves import import_logs

    rec = import_logs(args.logs)
    print(f"wrote {rec.save(args.out)} ({len(args.logs)} trials, {len(rec)} frames)")
    return 0


def cmd_train(args) -> int:
    from perception.learning.train import run

    if args.test and args.kind != "stir":
        raise FvtreeError("--test (a recording of another session) is for StirLearn (`fvtree train stir`)",
                          args.test)
    for path in run(args.kind, args.data, args.out, seed=args.seed, test=args.test):
        print(f"wrote {path}")
    return 0
