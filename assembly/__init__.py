"""The orchestrator: YAML tree language, runner, design-model bridge, CLI and test harness."""
