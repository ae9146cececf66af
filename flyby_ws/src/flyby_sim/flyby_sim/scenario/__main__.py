"""``python -m flyby_sim.scenario FILE [--seed N]`` / ``--schema-markdown`` (``scenario.load.main``)."""

from flyby_sim.scenario.load import main

if __name__ == '__main__':
    raise SystemExit(main())
