# gearsym: `make demo` runs the flagship demo, `make test` runs the test suite, `make docs`
# builds the documentation site (docs/_build/html; warnings are errors), `make dist` the
# wheel and sdist (dist/).  They create .venv (if missing) and install the project with
# every optional dependency (.[all,test]; `make docs` adds .[docs]).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

DOCSTAMP := $(VENV)/.installed-docs

.PHONY: demo test lint bench gallery clean docs dist

$(PY):
	$(PYTHON) -m venv $(VENV)

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[all,test]"
	touch $(STAMP)

$(DOCSTAMP): $(STAMP)
	$(PY) -m pip install --quiet -e ".[all,test,docs]"
	touch $(DOCSTAMP)

# the guides (docs/guides/*.py) and the notebook tour run during the build; -n -W: any warning,
# a cross-reference that does not resolve included, fails it; nothing is downloaded
docs: $(DOCSTAMP)
	$(PY) -m sphinx -E -n -W --keep-going -q -b html docs docs/_build/html
	@echo "docs/_build/html/index.html"

dist: $(STAMP)
	$(PY) -m build --no-isolation --outdir dist .

demo: $(STAMP)
	$(PY) examples/demo.py --out out

# small dense linear algebra is faster (and timing less erratic) without BLAS threads; the
# test files run on one worker process per core (pytest-xdist; a file's tests stay together,
# so its module fixtures -- compiled builds -- are made once); the slowest tests are listed
test: $(STAMP)
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(PY) -m pytest -q -n auto --dist loadfile --durations=20

lint: $(STAMP)
	$(VENV)/bin/ruff check gearsym tests benchmarks examples

bench: $(STAMP)
	$(PY) benchmarks/simulate_speed.py --out out/bench

clean:
	rm -rf out generated/*/ .pytest_cache docs/_build docs/auto_guides docs/notebooks docs/sg_execution_times.rst dist
