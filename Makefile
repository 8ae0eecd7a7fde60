# dronewind: two commands on a fresh machine.
#   make run   -> set up .venv and run the workflow on the embedded default campaign
#   make test  -> set up .venv and run the whole test suite
# The interpreter .venv is made from: the distribution's /usr/bin/python3.11 where it can make a
# venv, else the first python3.11 on PATH (`make PYTHON=/path/to/python3.11 ...` chooses).
PYTHON ?= $(shell /usr/bin/python3.11 -c 'import ensurepip, venv' >/dev/null 2>&1 && echo /usr/bin/python3.11 || echo python3.11)
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
CORES ?= 2
# the data folder of the real records (dronewind.datasets; `python -m dronewind.datasets fetch` fills it)
export DRONEWIND_DATA ?= $(abspath ../shared/data)
# pytest-xdist workers of `make test` (tests sharing a session or module fixture stay on one worker: tests/conftest.py)
TEST_WORKERS ?= 2

.PHONY: run test test-fast venv lint bench validate clean

$(STAMP): workflow/envs/requirements.txt workflow/envs/constraints.txt pyproject.toml
	@command -v $(PYTHON) >/dev/null 2>&1 || { echo "error: $(PYTHON) not found (Python 3.11 is required)"; exit 1; }
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -r workflow/envs/requirements.txt -c workflow/envs/constraints.txt
	$(BIN)/python -m pip install --quiet --no-deps -e .
	touch $(STAMP)

venv: $(STAMP)

run: $(STAMP)
	$(BIN)/snakemake --cores $(CORES)
	$(BIN)/snakemake --report results/mosai2023/report.html

test: $(STAMP)
	$(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadgroup --no-loadscope-reorder

# the fast tier: unit, property and known-answer tests of the library (no workflow runs, Monte-Carlo rate
# checks or fleet diagnoses: marked slow), under a minute
test-fast: $(STAMP)
	$(BIN)/python -m pytest -n $(TEST_WORKERS) -m "not slow" -q

lint: $(STAMP)
	$(BIN)/lint-imports --no-cache
	$(BIN)/ruff check src tests workflow/scripts benchmarks
	$(BIN)/mypy
	$(BIN)/snakemake --lint
	$(BIN)/snakefmt --check Snakefile workflow

# timing suite of single stages (pytest-benchmark, benchmarks/test_bench_*.py, about 2 min); results in .benchmarks/
bench: $(STAMP)
	$(BIN)/python -m pytest benchmarks -p no:cacheprovider -n 0 --benchmark-enable --benchmark-only --benchmark-autosave \
	    --benchmark-columns=min,median,rounds --benchmark-sort=name

# validation studies, each writing benchmarks/results/<study>.json (hours in all): make validate STUDY=<study>
validate: $(STAMP)
	$(BIN)/python benchmarks/validate.py $(STUDY)

clean:
	rm -rf results .snakemake
