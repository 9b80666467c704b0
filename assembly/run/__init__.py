"""One run of a tree on a cell: `Run` built from `RunOptions` (`session`), the tick loop (`loop`),
the run directory (`run_dir`), and the per-tick handlers: perception stage, stop policy, cell
supervisor, tip, transition log, load profiles, progress line."""
