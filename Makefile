# Two entry points, each self-sufficient on a fresh machine with Python >= 3.11.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)
export JAX_COMPILATION_CACHE_DIR ?= $(abspath $(VENV))/cache/jax
export JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS ?= 0.1
export MPLBACKEND ?= Agg
export PYTHONUNBUFFERED ?= 1

.PHONY: demo quick-demo test lint bench clean venv

venv: $(STAMP)

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[dev]"
	@rm -f $(VENV)/.installed-*
	@touch $(STAMP)

demo: venv
	$(VENV)/bin/symjax eval

quick-demo: venv
	$(VENV)/bin/symjax demo

# Two pytest workers, a test file each at a time (module fixtures stay in one process): the suite
# keeps the CI machine's 2 cores busy, where one process used 1.2 of them.
TEST_WORKERS ?= 2

test: venv
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadfile --durations=15

lint: venv
	$(PY) -m ruff check symjax tests scripts
	$(PY) -m ruff format --check symjax tests scripts

bench: venv
	@for b in scripts/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

clean:
	rm -rf $(VENV) .pytest_cache
