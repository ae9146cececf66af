"""foxglove/flyby_layout.json: the output of foxglove/make_layout.py, and every topic and frame it names is in a
default mission's bag (a layout naming a topic no run records shows an empty panel)."""

import importlib.util
import json
import re

import pytest
from rosbags.highlevel import AnyReader

from flyby_msgs_py import frames
from flyby_msgs_py.bag import bag_topics, jazzy_typestore
from flyby_testing import ROOT

LAYOUT = ROOT / 'foxglove' / 'flyby_layout.json'
SCRIPT_OUTPUT = '/studio_script/'


def _make_layout():
    spec = importlib.util.spec_from_file_location('make_layout', ROOT / 'foxglove' / 'make_layout.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _named(layout):
    """(topics the panels read, topics the user scripts read, topics the scripts write, frames) of a layout."""
    panel_topics, frame_ids = set(), set()

    def walk(node):
        if isinstance(node, dict):
            for key, value in node.items():
                if key == 'topics' and isinstance(value, dict):
                    panel_topics.update(value)
                elif key in ('value', 'topicPath') and isinstance(value, str) and value.startswith('/'):
                    panel_topics.add(value.split('.', 1)[0])
                elif key in ('followTf', 'frameId') and isinstance(value, str):
                    frame_ids.add(value)
                walk(value)
        elif isinstance(node, list):
            for item in node:
                walk(item)
    walk(layout['content'])
    inputs, outputs = set(), set()
    for script in layout['userScripts'].values():
        source = script['sourceCode']
        inputs.update(re.findall(r'"(/[^"]+)"', re.search(r'export const inputs = \[([^\]]*)\]', source)[1]))
        outputs.add(re.search(r'export const output = "([^"]+)"', source)[1])
    return panel_topics, inputs, outputs, frame_ids


def test_shipped_layout_is_make_layouts_output():
    assert LAYOUT.read_text() == _make_layout().layout_json(), 'run: .venv/bin/python foxglove/make_layout.py'


def test_layout_has_the_3d_scene_phase_plots_events_and_health_monitors():
    panels = re.findall(r'"panelType":\s*"(\w+)"', LAYOUT.read_text())
    assert sorted(panels) == ['DiagnosticsSummary', 'Plot', 'Plot', 'RawMessages', 'StateTransitions', 'ThreeDee']


@pytest.mark.slow
def test_every_topic_and_frame_the_layout_names_is_in_a_mission_bag(sixdof_short_run):
    """Panels read recorded topics or a user script's output; scripts read recorded topics; the 3D scene's frames
    are on /tf or /tf_static."""
    panel_topics, inputs, outputs, frame_ids = _named(json.loads(LAYOUT.read_text()))
    bag = sixdof_short_run / 'bag'
    recorded = bag_topics(bag)
    assert outputs and all(o.startswith(SCRIPT_OUTPUT) for o in outputs)
    assert sorted(t for t in panel_topics | inputs if t not in outputs and t not in recorded) == []
    assert outputs <= panel_topics  # every script's output is shown
    with AnyReader([bag], default_typestore=jazzy_typestore()) as reader:
        conns = [x for x in reader.connections if x.topic in (frames.TF_TOPIC, frames.TF_STATIC_TOPIC)]
        tf_frames = set()
        for conn, _t, raw in reader.messages(connections=conns):
            for t in reader.deserialize(raw, conn.msgtype).transforms:
                tf_frames |= {t.header.frame_id, t.child_frame_id}
    assert frame_ids and frame_ids <= tf_frames
