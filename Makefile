# sim2real — two commands: `make demo` and `make test`. Both build .venv from scratch if needed.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP_RUN := $(VENV)/.installed-run
STAMP_DEV := $(VENV)/.installed-dev
STAMP_TRAIN := $(VENV)/.installed-train
STAMP_DOCS := $(VENV)/.installed-docs
# RLlib (ray[rllib] 2.60) pins gymnasium==1.2.2, the main venv has gymnasium 1.4: its own venv
VENV_RLLIB := .venv-rllib
STAMP_RLLIB := $(VENV_RLLIB)/.installed-rllib
# One bytecode cache for every Python that make runs (installs, warm-up, lint, tests, docs,
# demo): .venv/pycache, also where the environment sets PYTHONDONTWRITEBYTECODE. Without it every
# pytest process (each xdist worker, the serial pass, the train tests) compiles and rewrites
# every test module again, about half of its collection time.
export PYTHONDONTWRITEBYTECODE :=
export PYTHONPYCACHEPREFIX := $(CURDIR)/$(VENV)/pycache
# Python then reads bytecode from that cache only, so pip's byte-compilation of every installed
# file into site-packages would never be read: the dev, train, docs and RLlib installs skip it
# (`--no-compile`: CPU torch alone is thousands of files) and a run compiles what it imports, once, into
# the cache.
# CPU torch first: this exact release is a ~190 MB CPU wheel; a bare `torch` requirement would
# pull a multi-GB CUDA build. Override e.g. TORCH='torch==2.9.1' on another platform.
TORCH ?= torch==2.13.0

.PHONY: demo test lint venv dev docs bench clean data train-extra rllib-extra test-train

# numba compiles the reduced drive model's kernels on their first use (~13 s of CPU) and keeps
# them in its on-disk cache (robots/_jit.py): a short fit at install compiles them once, so the
# first `sim2real sysid fit`, `sysid calibrate` or `agree --engine reduced` loads them instead.
# $(call warm,BIN-FOLDER)
warm = $(1)/sim2real sysid fit data/demo_train.mcap --robot turtlebot3_burger --window 0:20 \
	-o $(1)/../.warm-params.yaml > /dev/null

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(STAMP_RUN): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e .
	$(call warm,$(BIN))
	touch $@

# the [mujoco] extra with [dev]: its tests (`-m mujoco`) run in `make test`
$(STAMP_DEV): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q --no-compile -e '.[dev,mujoco]'
	$(call warm,$(BIN))
	touch $@ $(STAMP_RUN)

$(STAMP_TRAIN): pyproject.toml $(STAMP_DEV)
	$(BIN)/python -m pip install -q --no-compile '$(TORCH)'
	$(BIN)/python -m pip install -q --no-compile -e '.[dev,mujoco,train,cluster]'
	touch $@

$(STAMP_DOCS): pyproject.toml $(STAMP_RUN)
	$(BIN)/python -m pip install -q --no-compile -e '.[docs]'
	touch $@

$(STAMP_RLLIB): pyproject.toml
	$(PYTHON) -m venv $(VENV_RLLIB)
	$(VENV_RLLIB)/bin/python -m pip install -q --upgrade pip
	$(VENV_RLLIB)/bin/python -m pip install -q --no-compile '$(TORCH)'
	$(VENV_RLLIB)/bin/python -m pip install -q --no-compile -e '.[dev,train,rllib]'
	$(call warm,$(VENV_RLLIB)/bin)
	touch $@

venv: $(STAMP_RUN)
dev: $(STAMP_DEV)
## make train-extra: install the [train] and [cluster] extras (CPU torch, SB3, TensorBoard, Ray)
train-extra: $(STAMP_TRAIN)
## make rllib-extra: a second venv (.venv-rllib) with ray[rllib], which pins gymnasium 1.2.2
rllib-extra: $(STAMP_RLLIB)

## make demo: the README tour on the bundled logs (fit, calibrate the band, agreement + coverage on a third session); writes sim2real-demo/report.html
demo: $(STAMP_RUN)
	$(BIN)/sim2real demo --out sim2real-demo

## make lint: ruff + mypy
lint: $(STAMP_DEV)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy

## make test: lint, then the whole test suite, one worker per core up to four (pytest-xdist;
## `make test PYTEST_WORKERS=0` runs it in one process), then the `serial` tests alone (numba's
## on-disk cache, CPU-time budgets), which other workers' load or cache use could disturb
PYTEST_WORKERS ?= auto
test: lint
	$(BIN)/python -m pytest -q -n $(PYTEST_WORKERS) --maxprocesses 4 -m "not serial"
	$(BIN)/python -m pytest -q -m serial

## make docs: the documentation site into site/ (MkDocs + Material + mkdocstrings, the [docs]
## extra): the user guide in docs/, the CLI reference from the argument parsers and the API
## reference from the docstrings (scripts/mkdocs_hooks.py); --strict: any warning fails it
docs: $(STAMP_DOCS)
	NO_MKDOCS_2_WARNING=1 $(BIN)/python -m mkdocs build --strict --site-dir site

## make test-train: install the [train]/[cluster] extras (and .venv-rllib), then run the tests
## that need them, one worker per core up to four; the RLlib tests run in .venv-rllib (gymnasium 1.2.2)
test-train: $(STAMP_TRAIN) $(STAMP_RLLIB)
	$(BIN)/python -m pytest -q -n $(PYTEST_WORKERS) --maxprocesses 4 -m "train or cluster"
	$(VENV_RLLIB)/bin/python -m pytest -q tests/sim2real/training/test_train_rllib.py

## make bench: the performance targets (prints ratios measured in the same run) and writes
## docs/benchmarks.md from this run's headline figures (benchmarks/results_page.py); every bench
## runs even if one fails (exit 1 at the end, naming it). BENCH_QUICK=1: fewer repeats, a quick
## end-to-end check. Each bench's run time is printed and the whole run's goes into the page; a
## bench running longer than BENCH_TIMEOUT seconds is stopped and counted as failed.
## bench_dr_experiment.py (the [train] extra, minutes to hours) and bench_agree_ray.py (the
## [cluster] extra) are run by hand (their docstrings say how).
BENCHES ?= bench_perf.py bench_robots.py bench_replay.py bench_decode.py bench_bag.py \
	bench_envs.py bench_randomizers.py bench_plants.py bench_sysid.py bench_calibration.py \
	bench_car_race.py
BENCH_QUICK ?=
BENCH_TIMEOUT ?= 1800
bench: $(STAMP_DEV)
	rm -f benchmarks/.results.jsonl
	cd benchmarks && failed= && start=$$(date +%s) && for f in $(BENCHES); do \
	  echo "== $$f" && t0=$$(date +%s); \
	  BENCH_QUICK=$(BENCH_QUICK) timeout $(BENCH_TIMEOUT) ../$(BIN)/python $$f || failed="$$failed $$f"; \
	  echo "== $$f: $$(( $$(date +%s) - t0 )) s"; \
	done; \
	elapsed=$$(( $$(date +%s) - start )); echo "make bench: all benches in $$elapsed s"; \
	BENCH_QUICK=$(BENCH_QUICK) ../$(BIN)/python results_page.py --ran "$(BENCHES)" \
	  --failed "$$failed" --elapsed-s "$$elapsed"; \
	if [ -n "$$failed" ]; then echo "make bench: failed:$$failed" >&2; exit 1; fi

## make data: regenerate the synthetic sample logs in data/
data: $(STAMP_RUN)
	$(BIN)/python -m sim2real._samples data

clean:
	rm -rf $(VENV) $(VENV_RLLIB) sim2real-demo build site *.egg-info
