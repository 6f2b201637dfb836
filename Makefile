# The two commands a fresh machine needs: `make demo` and `make test`.
# `make test-all` adds the slow tier and the coverage floor; CI (.ci/run) runs it.
# Only python3 (3.11+) and make are assumed; everything else is installed
# into .venv on first use and reused afterwards.

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.stook-installed
# `make demo` needs only the runtime and the emulator, not the dev tools (Ray, a browser
# driver, mypy, mkdocs: most of the download); `make test` installs the rest.
DEMO_STAMP := $(VENV)/.stook-demo-installed
PYPROJECTS := pyproject.toml proto/pyproject.toml sdk/pyproject.toml service/pyproject.toml \
	service/testing/pyproject.toml
PIP := $(BIN)/python -m pip install --quiet --disable-pip-version-check

.PHONY: setup test test-all lint typecheck pytest pytest-all docs demo proto bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

# Re-install only when a pyproject changes; a second `make test` is fast.
$(STAMP): $(BIN)/python $(PYPROJECTS)
	@echo "Installing stook with its dev tools into $(VENV) (first run only; a few minutes)"
	$(PIP) --upgrade "pip>=25.1"
	$(PIP) --group dev -e ./proto -e ./sdk -e './service[ray]' -e './service/testing[pytest,bench]'
	# Byte-compiled once, as a wheel install is: under PYTHONDONTWRITEBYTECODE an editable
	# checkout would otherwise compile every stook module in every process.
	$(BIN)/python -m compileall -q proto/src sdk/src service/src service/testing/src
	touch $(STAMP) $(DEMO_STAMP)

# What a full install already has, the demo does not install again.
$(DEMO_STAMP): $(BIN)/python $(PYPROJECTS)
	@echo "Installing stook and its emulator into $(VENV) (first run only)"
	$(PIP) -e ./proto -e ./sdk -e ./service -e ./service/testing
	$(BIN)/python -m compileall -q proto/src sdk/src service/src service/testing/src
	touch $(DEMO_STAMP)

setup: $(STAMP)

lint: setup
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

typecheck: setup
	$(BIN)/mypy

# Over every core (pytest-xdist). `make test` leaves out the tests marked slow (a real
# browser, Ray, the long outages, wheel builds, the benchmarks' smoke runs); `make test-all`
# runs everything, each property with all its examples (tests/hypothesis_profiles.py), and
# measures coverage against its floor (tool.coverage in pyproject.toml).
pytest: setup
	HYPOTHESIS_PROFILE=quick $(BIN)/pytest -n auto -m "not slow"

pytest-all: setup
	$(BIN)/pytest -n auto --cov --cov-report=term

# The docs site (mkdocs.yml): --strict, so a broken link or a missing page fails (not
# --quiet: it hides the warnings that --strict counts).
docs: setup
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

test: lint typecheck pytest docs

test-all: lint typecheck pytest-all docs

demo: $(DEMO_STAMP)
	$(BIN)/stook demo

proto: setup
	$(BIN)/python -m tools.generate_proto

# The full sweep (tens of minutes; results into docs/benchmarks/), then the decode and
# reduce micro-benchmarks with timing on (the normal test run only smoke-tests them).
bench: setup
	$(BIN)/stook bench
	$(BIN)/pytest tests/bench --benchmark-enable --benchmark-only

clean:
	rm -rf $(VENV) demo-output site .pytest_cache .mypy_cache .ruff_cache .hypothesis .coverage .coverage.*
