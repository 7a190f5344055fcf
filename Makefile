# tmaplan — the two set-up commands: `make demo` and `make test`.
PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: test test-kernels test-slow demo docs lint typecheck bench clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

lint: $(STAMP)
	$(BIN)/ruff check tmaplan tests docs $(wildcard benchmarks notebooks/*.py)

typecheck: $(STAMP)
	$(BIN)/mypy  # files: [tool.mypy] in pyproject.toml (the whole tmaplan/ package)

test: $(STAMP) lint typecheck
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -m "not slow" -n auto  # one worker per core (pytest-xdist)

# The tests marked solver_sensitive (their outcome depends on a numerical path) again under two
# other sets of numerical kernels: an older CPU's (numpy at its SIMD baseline, OpenBLAS on Sandy
# Bridge kernels, one BLAS thread, glibc's libm without FMA) and one without AVX-512 (OpenBLAS on
# Haswell kernels, two threads); tests/kernels.py prints each setting and what it loaded.
test-kernels: $(STAMP)
	$(BIN)/python tests/kernels.py -n auto

test-slow: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -m slow

demo: $(STAMP)
	MPLBACKEND=Agg $(BIN)/tmaplan demo --out out

DOCS_STAMP := $(VENV)/.installed-docs

$(DOCS_STAMP): pyproject.toml $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[dev,docs]'
	touch $(DOCS_STAMP)

# The documentation site (docs/_build/html); every warning is an error.
docs: $(DOCS_STAMP)
	MPLBACKEND=Agg $(BIN)/sphinx-build -W --keep-going -q -b html docs docs/_build/html

bench: $(STAMP)
	for b in benchmarks/*.py; do $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) out .pytest_cache docs/_build docs/_generated docs/api
