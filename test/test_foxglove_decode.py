"""A mission's bag read by Foxglove's own readers (test/js/decode_bag.js: @mcap/core, @foxglove/rosmsg2-serialization)
as the Foxglove app reads it: every message decodes, none holds a NaN (a JointState field not given is empty), and
/tf carries the bodies' frames. `make test-all` installs test/js (test/js/install.sh); elsewhere the tests are
skipped without it, but never in CI (CI set), where a missing reader fails them."""

import json
import os
import shutil
import subprocess

import pytest

from flyby_testing import ROOT

JS = ROOT / 'test' / 'js'
NODE = shutil.which('node')

INSTALLED = NODE is not None and (JS / 'node_modules' / '@mcap' / 'core').is_dir()

pytestmark = pytest.mark.skipif(not INSTALLED and not os.environ.get('CI'),
                                reason='Foxglove readers not installed: sh test/js/install.sh (node and npm)')


def decode(mcap):
    assert INSTALLED, 'Foxglove readers not installed: sh test/js/install.sh (node and npm)'
    done = subprocess.run([NODE, str(JS / 'decode_bag.js'), str(mcap)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout)


@pytest.mark.slow
def test_foxglove_reads_every_message_without_nan_and_finds_the_frames(sixdof_short_run):
    (mcap,) = (sixdof_short_run / 'bag').glob('*.mcap')
    out = decode(mcap)
    assert out['errors'] == []
    assert {t: v['nan'] for t, v in out['topics'].items() if v['nan']} == {}
    for topic in ('/sim/chaser/wheels', '/sim/chaser/thrusters', '/guidance/wheels', '/tf'):
        assert out['topics'][topic]['messages'] > 100, topic
    assert out['topics']['/tf_static']['messages'] == 1
    assert {'hill->target_body', 'hill->chaser_body', 'target_body->grasp_point'} <= set(out['tf_frames'])


def test_decoder_refuses_a_wrong_command_line():
    done = subprocess.run([NODE, str(JS / 'decode_bag.js')], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and done.stderr.startswith('usage: node decode_bag.js BAG.mcap')
