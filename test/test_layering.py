"""The structure rules of DESIGN §2 and §10, read from the source tree itself.

- Every module that is not a node (or the node runtime, or the QoS profiles) imports without rclpy:
  the cores can run in a plain process (the headless driver, a Dask worker).
- Estimation, planning and guidance never import the plant, the sensor models, the thruster model or
  the simulator node: only the drivers wire the plant in (the headless driver, scripts, tests).
- Each module imports only from its own package or the packages below it.
"""

import ast
import json
import subprocess
import sys

import pytest

from flyby_testing import ROOT

SRC = ROOT / 'flyby_ws' / 'src'
# Bottom to top: a module may import its own package and those before it.
LAYERS = ('flyby_msgs_py', 'flyby_sim', 'flyby_estimation', 'flyby_planner', 'flyby_guidance', 'flyby_mission')
# Modules that are ROS by purpose, besides the nodes (*_node.py).
ROS_MODULES = {
    'flyby_msgs_py.runtime': 'runs nodes: executor loop, progress, readiness, signals',
    'flyby_msgs_py.qos': 'the QoS profiles are rclpy objects',
    'flyby_msgs_py.node_base': 'the base class of the nodes is an rclpy Node',
    'flyby_mission.launcher': 'prepares a graph run: its ROS environment, the node specs, the graph run itself',
    'flyby_mission.graph_run': 'runs the node graph: the nodes as processes or on one executor, its monitor node',
}
PLANT_MODULES = ('flyby_sim.plant', 'flyby_sim.sensors', 'flyby_sim.thrusters', 'flyby_sim.sim_node')
# The headless driver wires the plant in, as the launcher wires the sim node in.
DRIVERS = ('flyby_mission.headless',)


def _modules():
    """(dotted name, path) of every module of the packages (tests excluded)."""
    for package in LAYERS:
        root = SRC / package
        for path in sorted((root / package).rglob('*.py')):
            parts = path.relative_to(root).with_suffix('').parts
            name = '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)
            yield name, path


def _imports(path):
    """Every module name a file imports (absolute imports), at any depth of the file."""
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module
            yield from (f'{node.module}.{a.name}' for a in node.names)


def _is_ros(name):
    return name.endswith('_node') or name in ROS_MODULES


CORE_MODULES = [name for name, _ in _modules() if not _is_ros(name)]


def test_every_core_module_imports_without_rclpy():
    """A fresh interpreter imports every non-node module; rclpy is not loaded by any of them."""
    code = ('import importlib, json, sys\n'
            f'names = {CORE_MODULES!r}\n'
            'loaded = {}\n'
            'for name in names:\n'
            '    importlib.import_module(name)\n'
            "    loaded[name] = any(m == 'rclpy' or m.startswith('rclpy.') for m in sys.modules)\n"
            'print(json.dumps(loaded))\n')
    done = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert done.returncode == 0, done.stderr
    loaded = json.loads(done.stdout)
    assert len(loaded) == len(CORE_MODULES) > 40
    first = next((name for name in CORE_MODULES if loaded[name]), None)
    assert first is None, f'importing {first} loads rclpy'


def test_the_ros_modules_are_the_nodes_and_the_runtime():
    """The exemption list stays short and true: each exempted module imports rclpy, or a module that does (a
    node through its base class, node_base; the launcher through the graph run)."""
    for name, path in _modules():
        if _is_ros(name):
            ros = [m for m in _imports(path) if m == 'rclpy' or m.startswith(('rclpy.', 'flyby_msgs_py.node_base'))
                   or (m != name and _is_ros(m))]
            assert ros, name


@pytest.mark.parametrize('package', ('flyby_estimation', 'flyby_planner', 'flyby_guidance'))
def test_no_plant_in_estimation_planning_guidance(package):
    offenders = [(name, m) for name, path in _modules() if name.split('.')[0] == package and name not in DRIVERS
                 for m in _imports(path) if m.startswith(PLANT_MODULES)]
    assert offenders == []


def test_each_module_imports_only_its_own_package_and_lower():
    offenders = []
    for name, path in _modules():
        level = LAYERS.index(name.split('.')[0])
        for m in _imports(path):
            top = m.split('.')[0]
            if top in LAYERS and LAYERS.index(top) > level:
                offenders.append((name, m))
    assert offenders == []


def test_package_xml_declares_every_flyby_package_imported():
    for package in LAYERS:
        xml = (SRC / package / 'package.xml').read_text()
        used = {m.split('.')[0] for name, path in _modules() if name.split('.')[0] == package
                for m in _imports(path)}
        for other in sorted(used & set(LAYERS) - {package}):
            assert f'<exec_depend>{other}</exec_depend>' in xml, f'{package}/package.xml lacks {other}'


def test_every_node_has_a_console_script():
    for name, _ in _modules():
        if name.endswith('_node'):
            package = name.split('.')[0]
            setup = (SRC / package / 'setup.py').read_text()
            assert f'= {name}:main' in setup, f'{package}/setup.py has no console script for {name}'
