# gearsym: `make demo` runs the flagship demo, `make test` runs the test suite.
# Both create .venv (if missing) and install the project with its dependencies.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test lint bench gallery clean

$(PY):
	$(PYTHON) -m venv $(VENV)

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test]"
	touch $(STAMP)

demo: $(STAMP)
	$(PY) examples/demo.py --out out

# small dense linear algebra is faster (and timing less erratic) without BLAS threads
test: $(STAMP)
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(PY) -m pytest -q

lint: $(STAMP)
	$(VENV)/bin/ruff check gearsym tests benchmarks examples

bench: $(STAMP)
	$(PY) benchmarks/simulate_speed.py --out out/bench

clean:
	rm -rf out generated/*/ .pytest_cache
