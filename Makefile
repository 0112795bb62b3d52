# sim2real — two commands: `make demo` and `make test`. Both build .venv from scratch if needed.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP_RUN := $(VENV)/.installed-run
STAMP_DEV := $(VENV)/.installed-dev

.PHONY: demo test lint venv dev bench clean data

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(STAMP_RUN): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e .
	touch $@

$(STAMP_DEV): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e '.[dev]'
	touch $@ $(STAMP_RUN)

venv: $(STAMP_RUN)
dev: $(STAMP_DEV)

## make demo: fit sysid on the bundled training log, measure agreement, write sim2real-demo/report.html
demo: $(STAMP_RUN)
	$(BIN)/sim2real demo --out sim2real-demo

## make lint: ruff + mypy
lint: $(STAMP_DEV)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy

## make test: lint, then the whole test suite
test: lint
	$(BIN)/python -m pytest -q

## make bench: the performance targets (prints ratios measured in the same run)
bench: $(STAMP_DEV)
	for f in benchmarks/bench_*.py; do $(BIN)/python $$f || exit 1; done

## make data: regenerate the synthetic sample logs in data/
data: $(STAMP_RUN)
	$(BIN)/python -m sim2real._samples data

clean:
	rm -rf $(VENV) sim2real-demo build *.egg-info
