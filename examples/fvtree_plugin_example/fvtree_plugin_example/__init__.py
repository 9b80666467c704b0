"""An example fvtree plug-in: the `pinch` skill and the `light_box` scene, found by fvtree through
the entry points in this package's pyproject.toml (no change to fvtree itself)."""
