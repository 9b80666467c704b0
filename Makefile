# Two entry points: `make run` (the assembly on the simulated cell) and `make test`; `make test-fast`
# is the quick tier for development (every test but the long end-to-end runs marked `slow`).
# All create .venv and install the project on first use.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

# Tests run in parallel (pytest-xdist) on one worker more than there are cores: some tests wait on the
# wall clock (emulators, watchdogs, brokers), and meanwhile the others keep the cores busy (two cores:
# 4:06 with three workers, 4:50 with two). A module's tests stay on one worker, so that its
# module-scoped fixtures (a recorded run, a broker, ...) are made once.
WORKERS ?= $(shell $(PYTHON) -c "import os; print(os.cpu_count() + 1)")
PYTEST   = $(BIN)/python -m pytest -n $(WORKERS) --dist loadscope

.PHONY: run test test-fast clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/fvtree run trees/assembly.yaml --cell sim

test: $(STAMP)
	$(PYTEST)

test-fast: $(STAMP)
	$(PYTEST) -m "not slow"

clean:
	rm -rf $(VENV) runs bench *.egg-info
