# Two entry points: `make run` (the assembly on the simulated cell) and `make test`.
# Both create .venv and install the project on first use.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/fvtree run trees/assembly.yaml --cell sim

test: $(STAMP)
	$(BIN)/python -m pytest

clean:
	rm -rf $(VENV) runs bench *.egg-info
