"""Scenario files (DESIGN §6): the flyby schema, a validating loader and a read-only Scenario.

A scenario is one YAML file. ``SCHEMA`` (``scenario.schema``) names every key with its type, default (or
REQUIRED), validated range and a one-line description (the engine is ``flyby_msgs_py.schema``);
``docs/scenario.md`` embeds the table that ``schema_markdown()`` renders from it (a test keeps the
two identical). Adding a key is one line in ``SCHEMA``.

    sc = load_scenario('scenarios/paper_flyby.yaml')
    sc.chaser.thrusters.isp_s          # 220.0, defaults filled in, read-only
    sc.q_hill_from_body0               # unit quaternion (x, y, z, w), scalar last
    sc.omega_body0_rad_s               # inertial angular velocity of the target in body axes

Every problem raises ``flyby_msgs_py.schema.ScenarioError`` (a ``ValueError``) whose message is one
line naming the file, the dotted key path and the problem, e.g.
``scenarios/x.yaml: chaser.mass_kg: must be > 0, got -5.0``.

Quaternion convention: (x, y, z, w), scalar last, as ``flyby_sim.dynamics.rotation``.
``q_hill_from_body`` rotates body components into hill components: ``v_hill = R(q_hill_from_body) @ v_body``.

The modules: ``schema`` (the key table), ``checks`` (what a range cannot express: per key and across keys),
``view`` (the read-only ``Scenario`` and its derived values, ``Boxes``), ``load`` (the entry points).
"""

from flyby_msgs_py.schema import ScenarioError, load_yaml_mapping
from flyby_sim.scenario.load import load_scenario, main, scenario_from_dict, scenario_of, schema_markdown
from flyby_sim.scenario.schema import MAX_STEP_S, SCHEMA, SEED_MAX
from flyby_sim.scenario.view import Boxes, Scenario

__all__ = ['MAX_STEP_S', 'SCHEMA', 'SEED_MAX', 'Boxes', 'Scenario', 'ScenarioError', 'load_scenario',
           'load_yaml_mapping', 'main', 'scenario_from_dict', 'scenario_of', 'schema_markdown']
