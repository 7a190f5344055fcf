# tmaplan — the two set-up commands: `make demo` and `make test`.
PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: test test-slow demo lint typecheck bench clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

lint: $(STAMP)
	$(BIN)/ruff check tmaplan tests $(wildcard benchmarks notebooks/*.py)

typecheck: $(STAMP)
	$(BIN)/mypy --follow-imports=silent tests/typing/public_api.py

test: $(STAMP) lint typecheck
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -m "not slow"

test-slow: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -m slow

demo: $(STAMP)
	MPLBACKEND=Agg $(BIN)/tmaplan demo --out out

bench: $(STAMP)
	for b in benchmarks/*.py; do $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) out .pytest_cache
