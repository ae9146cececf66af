#!/usr/bin/env python3
"""Write foxglove/flyby_layout.json, the Foxglove layout of a flyby run (its bag, or live with --foxglove).

    .venv/bin/python foxglove/make_layout.py [--out foxglove/flyby_layout.json]

Built with the foxglove-sdk's layout classes (``foxglove.layouts``), so the file is in Foxglove's own layout
format: the 3D scene in ``hill`` (the target's boxes and the chaser's envelope from /visualization/markers, the
bodies' axes from /tf and /tf_static, the planned path), the phase as a state timeline, the range and the distance
to the planned capture point (two user scripts: Foxglove's plots take no norm of a vector), and the events.
test/test_foxglove_layout.py checks that the shipped file is this script's output and that every topic it names
is in a default mission's bag.
"""

import argparse
import json
import sys
from pathlib import Path

import foxglove.layouts as fl

from flyby_msgs_py import contract as c
from flyby_msgs_py import frames

OUT = Path(__file__).resolve().parent / 'flyby_layout.json'
RANGE_TOPIC = '/studio_script/range'
CAPTURE_TOPIC = '/studio_script/capture_distance'
CHASER_ODOM, PHASE, EVENTS, DIAGNOSTICS = (c.absolute(t) for t in (c.SIM_CHASER_ODOM, c.MISSION_PHASE, c.MISSION_EVENTS,
                                                                c.DIAGNOSTICS))
FLYBY_TARGET, PATH, MARKERS = (c.absolute(t) for t in (c.PLANNER_FLYBY_TARGET, c.PLANNER_PATH, c.MARKERS))

RANGE_SCRIPT = f'''// The chaser's range to the target's centre of mass (the hill origin) [m], from the truth.
import {{ Input }} from "./types";
export const inputs = ["{CHASER_ODOM}"];
export const output = "{RANGE_TOPIC}";
export default function script(event: Input<"{CHASER_ODOM}">): {{ range_m: number }} {{
  const p = event.message.pose.pose.position;
  return {{ range_m: Math.hypot(p.x, p.y, p.z) }};
}}
'''

CAPTURE_SCRIPT = f'''// The chaser's distance to the planned capture point (the fly-by target of the latest plan) [m]:
// at the grasp time, close to the summary's capture position error (taken against the true target's attitude).
import {{ Input }} from "./types";
export const inputs = ["{CHASER_ODOM}", "{FLYBY_TARGET}"];
export const output = "{CAPTURE_TOPIC}";
let target: {{ x: number; y: number; z: number }} | undefined;
export default function script(
  event: Input<"{CHASER_ODOM}"> | Input<"{FLYBY_TARGET}">,
): {{ distance_m: number }} | undefined {{
  const p = event.message.pose.pose.position;
  if (event.topic === "{FLYBY_TARGET}") {{
    target = p;
    return undefined;
  }}
  if (target === undefined) return undefined;
  return {{ distance_m: Math.hypot(p.x - target.x, p.y - target.y, p.z - target.z) }};
}}
'''


def layout():
    """The layout: the 3D scene on the left; the phase, the two plots and the events on the right."""
    scene = fl.ThreeDeePanel(title='hill frame', config=fl.ThreeDeeConfig(
        follow_tf=c.FRAME_HILL, follow_mode='follow-pose',
        topics={MARKERS: fl.BaseRendererRosMarkerTopicSettings(visible=True),
                PATH: fl.BaseRendererPosesTopicSettings(visible=True)},
        layers={'grid': fl.BaseRendererGridLayerSettings(frame_id=c.FRAME_HILL, size=20.0)}))
    phase = fl.StateTransitionsPanel(title='phase', config=fl.StateTransitionsConfig(
        paths=[fl.StateTransitionsSeries(value=f'{PHASE}.data', label='phase')]))
    range_plot = fl.PlotPanel(title='range [m]', config=fl.PlotConfig(
        paths=[fl.PlotSeries(value=f'{RANGE_TOPIC}.range_m', label='range to the target [m]')]))
    capture_plot = fl.PlotPanel(title='capture error [m]', config=fl.PlotConfig(
        paths=[fl.PlotSeries(value=f'{CAPTURE_TOPIC}.distance_m', label='to the planned capture point [m]')],
        min_y_value=0.0))
    events = fl.RawMessagesPanel(title='events', config=fl.RawMessagesConfig(topic_path=f'{EVENTS}.status'))
    health = fl.DiagnosticsSummaryPanel(title='health monitors', config=fl.DiagnosticsSummaryConfig(
        topic_to_render=DIAGNOSTICS, sort_by_level=True))
    right = fl.SplitContainer(direction='column', items=[
        fl.SplitItem(proportion=1, content=phase), fl.SplitItem(proportion=2, content=range_plot),
        fl.SplitItem(proportion=2, content=capture_plot), fl.SplitItem(proportion=2, content=events),
        fl.SplitItem(proportion=1, content=health)])
    return fl.Layout(
        content=fl.SplitContainer(direction='row', items=[fl.SplitItem(proportion=3, content=scene),
                                                          fl.SplitItem(proportion=2, content=right)]),
        user_scripts={'range': fl.UserScript(name='range', source_code=RANGE_SCRIPT),
                      'capture_distance': fl.UserScript(name='capture distance', source_code=CAPTURE_SCRIPT)})


def layout_json():
    """The layout file's text: indented JSON, keys in Foxglove's order."""
    return json.dumps(json.loads(layout().to_json()), indent=2) + '\n'


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--out', type=Path, default=OUT, help=f'layout file to write (default {OUT.name})')
    args = ap.parse_args(argv)
    args.out.write_text(layout_json())
    print(f'layout: {args.out} (frames {c.FRAME_HILL}, {c.FRAME_TARGET_BODY}, {c.FRAME_CHASER_BODY} on '
          f'{frames.TF_TOPIC})', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
