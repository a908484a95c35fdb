# `make test`, `make demo` and `make docs` each create (or reuse) .venv in this folder and install what they need:
# the demo only the package and numba (a stamp of its own), the rest the test extra (docs, plots, dask, tools).
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
DEMO_STAMP := $(VENV)/.installed-demo-stamp
# -W: a warning (a broken cross-reference, a failing notebook cell) fails the build.
SPHINXOPTS ?= -W --keep-going
DOCS_OUT ?= docs/_build

.PHONY: test test-fast demo docs lint bench clean

$(PY):
	python3 -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e ".[test]"
	touch $(STAMP)

# What `impactosc demo` runs on: the dependencies and numba (the compiled event rules), not the test extra.
$(DEMO_STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e ".[fast]"
	touch $(DEMO_STAMP)

lint: $(STAMP)
	$(PY) -m ruff check impactosc tests benchmarks docs/conf.py docs/_ext
	$(VENV)/bin/lint-imports --no-cache  # the layers of pyproject.toml [tool.importlinter]: names any import that breaks them

# The complete check (CI runs it: .ci/run).
test: $(STAMP) lint
	$(PY) -m pytest -q

# The loop while you work: the lint and every test but those marked slow (see pyproject's markers).
test-fast: $(STAMP) lint
	$(PY) -m pytest -q -m "not slow"

demo: $(DEMO_STAMP)
	$(PY) -m impactosc demo

# The whole site from scratch (-E, and a fresh html folder): the notebooks are executed again, in quick mode.
docs: $(STAMP)
	rm -rf $(DOCS_OUT)/html  # no page of a removed module or notebook survives from an earlier build
	$(PY) -m sphinx -b html -E $(SPHINXOPTS) -d $(DOCS_OUT)/doctrees docs $(DOCS_OUT)/html
	@echo "The site is in $(DOCS_OUT)/html/index.html"

bench: $(STAMP)
	$(PY) benchmarks/heyoka_speed.py

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache .hypothesis .mypy_cache build dist $(DOCS_OUT) \
		docs/api/generated docs/api/modules docs/api/cli.rst docs/api/index.rst
