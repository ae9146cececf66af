# The commands of the README: `make mission`, `make test` and `make test-all`.
# Both create .venv from requirements.txt on first use; nothing is sourced or installed by hand.
PYTHON_BOOT ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
JS_STAMP := test/js/node_modules/.installed
PACKAGES := $(wildcard flyby_ws/src/*/setup.py)
SCENARIO ?= scenarios/paper_flyby_6dof.yaml
OUT ?= runs/paper_flyby_6dof
PYTEST_ARGS ?=

.PHONY: mission test test-all lint venv benchmark clean-runs

$(STAMP): requirements.txt $(PACKAGES)
	$(PYTHON_BOOT) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.txt
	$(PY) -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation \
		$(foreach p,$(PACKAGES),-e $(dir $(p)))
	touch $(STAMP)

venv: $(STAMP)

# Exit code 3 (no capture, but safe: escape, abort, time limit) is an outcome, not a failure of make.
mission: $(STAMP)
	$(PY) scripts/run_mission.py --scenario $(SCENARIO) --out $(OUT) --force \
		|| [ $$? -eq 3 ]

# Two tiers by the `slow` marker (pytest.ini, docs/testing.md), both on both cores: tests grouped by file (a file's
# module fixtures, a mission flown once for its tests, are flown once), each test on its own ROS domain.
#   make test      the fast tier, -m "not slow": unit and property tests, refusals, a few short graph and headless
#                  missions; under 5 minutes on 2 cores.
#   make test-all  every test: the fast tier and the slow one (long graph missions and headless scenarios,
#                  campaigns). CI runs it (.ci/run).
# PYTEST_ARGS is passed to pytest after the tier's options: make test PYTEST_ARGS="test/test_wiring.py -x" runs one
# file; a -m in it replaces the tier's: make test-all PYTEST_ARGS="-m slow" runs the slow tier alone.
test: $(STAMP)
	$(PY) -m pytest -n 2 --dist loadfile -m "not slow" $(PYTEST_ARGS)

test-all: $(STAMP) $(JS_STAMP)
	$(PY) -m pytest -n 2 --dist loadfile $(PYTEST_ARGS)

# Foxglove's own readers of a bag (test/test_foxglove_decode.py), pinned in test/js/package-lock.json (node, npm).
$(JS_STAMP): test/js/package-lock.json
	sh test/js/install.sh
	touch $(JS_STAMP)

# ruff over the whole tree (rules and line length in ruff.toml).
lint: $(STAMP)
	$(VENV)/bin/ruff check .

benchmark: $(STAMP)
	$(PY) scripts/bench/benchmark_sim.py

clean-runs:
	rm -rf runs
