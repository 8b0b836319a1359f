# `make demo` and `make test` each do the whole set-up first (see scripts/setup.sh).
VENV ?= .venv
BIN := $(VENV)/bin

.PHONY: setup demo test lint bench clean
setup:
	@bash scripts/setup.sh

demo: setup
	$(BIN)/flexhrc demo table

test: setup
	$(BIN)/python -m pytest -q

lint: setup
	$(BIN)/ruff check src tests benchmarks scripts
	$(BIN)/ruff format --check src tests benchmarks scripts
	$(BIN)/mypy src/flexhrc

bench: setup
	$(BIN)/python benchmarks/andor_paper.py

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info src/*.egg-info
	find src -name '*.so' -delete
