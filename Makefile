# Two entry points: `make all` regenerates every study, `make test` runs the quick tier of the
# tests (make test-long the second, make test-all both; CI runs both: .ci/run).
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: all test test-long test-all lint slurm bench lock clean

all: $(STAMP)
	$(BIN)/snakemake all -c 2
	@echo "results: data/index.html (every study, run, sweep, scene and benchmark built;" \
	  "in a terminal: $(BIN)/creatio ls, then $(BIN)/creatio open NAME)"

# The quick tier on every core, up to 4 (pytest-xdist): whole test modules per worker, so a
# module's fixtures are built once; `pytest` alone runs it in one process.
test: $(STAMP)
	$(BIN)/python -m pytest -n auto --maxprocesses 4 --dist loadfile

test-long: $(STAMP)
	$(BIN)/python -m pytest -m 'long and not slow'

test-all: $(STAMP)
	$(BIN)/python -m pytest -m 'not slow'

lint: $(STAMP)
	$(BIN)/ruff check src tests scripts
	$(BIN)/snakemake --lint

slurm: $(STAMP)
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[slurm]'

bench: $(STAMP)
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[bench]'
	$(BIN)/python scripts/bench_en02.py
	$(BIN)/python scripts/bench_kinematics.py
	$(BIN)/snakemake benchmarks -c 1

$(STAMP): pyproject.toml constraints.txt
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[dev]'
	touch $(STAMP)

lock: $(STAMP)
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[dev,slurm,bench]'
	$(BIN)/python -m pip freeze --exclude-editable | sed '1i # Exact versions for every install (make bootstraps with pip -c constraints.txt).\n# Regenerate: make lock' > constraints.txt

clean:
	rm -rf $(VENV) .snakemake
