# The two commands of the README: `make mission` and `make test`.
# Both create .venv from requirements.txt on first use; nothing is sourced or installed by hand.
PYTHON_BOOT ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
PACKAGES := $(wildcard flyby_ws/src/*/setup.py)
SCENARIO ?= scenarios/paper_flyby_6dof.yaml
OUT ?= runs/paper_flyby_6dof
PYTEST_ARGS ?=

.PHONY: mission test lint venv benchmark clean-runs

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

# Both cores: tests grouped by file (a file's session fixtures are flown once), each test on its own ROS domain.
test: $(STAMP)
	$(PY) -m pytest -n 2 --dist loadfile $(PYTEST_ARGS)

# ruff over the whole tree (rules and line length in ruff.toml).
lint: $(STAMP)
	$(VENV)/bin/ruff check .

benchmark: $(STAMP)
	$(PY) scripts/bench/benchmark_sim.py

clean-runs:
	rm -rf runs
