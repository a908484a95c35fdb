# `make test` and `make demo` each create (or reuse) .venv in this folder and install what they need.
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp

.PHONY: test demo lint bench clean

$(STAMP): pyproject.toml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test]"
	touch $(STAMP)

lint: $(STAMP)
	$(PY) -m ruff check impactosc tests benchmarks

test: $(STAMP) lint
	$(PY) -m pytest -q

demo: $(STAMP)
	$(PY) -m impactosc demo

bench: $(STAMP)
	$(PY) benchmarks/heyoka_speed.py

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .hypothesis
