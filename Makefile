# navstack developer entry points.  `make demo`, `make test` and `make docs` create .venv
# on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# numba's on-disk cache lives in the project (gitignored) so a fresh clone can write it.
export NUMBA_CACHE_DIR := $(CURDIR)/.cache/numba
export MPLBACKEND := Agg
# Material for MkDocs prints a banner about its future on every build; not a warning of ours
export NO_MKDOCS_2_WARNING := 1
OUT ?= runs/demo

.PHONY: venv demo test lint typecheck pytest docs bench clean

venv: $(STAMP)

# uv resolves and installs the same pins as pip in seconds rather than minutes; pip is the
# fallback where uv cannot run
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	( $(BIN)/python -m pip install --quiet uv \
		&& $(BIN)/uv pip install --quiet --python $(BIN)/python -e '.[dev,docs]' ) \
		|| $(BIN)/python -m pip install --quiet -e '.[dev,docs]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/navstack demo --out $(OUT) --seed 1

test: lint typecheck pytest docs

lint: $(STAMP)
	$(BIN)/ruff check src tests docs/hooks

typecheck: $(STAMP)
	$(BIN)/mypy

# one test process per core (at most 4; pytest-xdist), the long integration runs handed to
# whichever process is free (--dist worksteal); `PYTEST_ARGS=-n0` runs them in one process
PYTEST_ARGS ?= -n auto --maxprocesses=4 --dist worksteal
pytest: $(STAMP)
	$(BIN)/python -m pytest $(PYTEST_ARGS)

# the user guide into site/, every warning an error; the reference pages are generated
# from the code by docs/hooks/ during the build (nothing generated is committed)
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet

bench: $(STAMP)
	$(BIN)/navstack bench sim --json runs/bench-sim.json

clean:
	rm -rf $(VENV) .cache .pytest_cache .mypy_cache .ruff_cache runs site
