"""The supervisor's own core raising in the graph (docs/runtime.md): guidance idles propulsion on its node_error, the
run goes on to its duration and ends in ERROR saying why, as headless (flyby_mission/test/test_supervisor_lost.py).
Every node real, in this process, on its own ROS domain (the launcher's lease)."""

from flyby_mission.headless import HeadlessGraph, run_headless
from flyby_msgs_py import contract as c
from flyby_msgs_py import events
from flyby_msgs_py.bag import read_bag
from flyby_sim.scenario import load_scenario
from flyby_testing import write_scenario

T_FAULT_S = 100.0  # TERMINAL_APPROACH: after the transfer burn (70 s), before the midcourse burn (292 s)


def _raising(core_class):
    """A supervisor core class that raises at its first chaser estimate stamped at or after T_FAULT_S."""
    class Raising(core_class):
        def on_chaser_estimate(self, t, *args):
            if t >= T_FAULT_S:
                raise ZeroDivisionError(f'injected supervisor fault at t = {t:.2f} s')
            return super().on_chaser_estimate(t, *args)
    return Raising


def _short(data):
    data['simulation']['duration_s'] = 130.0


def test_a_supervisor_exception_in_the_graph_idles_propulsion_and_ends_in_error_as_headless(tmp_path, monkeypatch):
    from flyby_mission import supervisor_node
    from flyby_mission.launcher import LaunchOptions, run

    for name in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'FASTRTPS_DEFAULT_PROFILES_FILE'):
        monkeypatch.setenv(name, '')  # the launcher sets them for its run; restored afterwards
    monkeypatch.setattr(supervisor_node, 'SupervisorCore', _raising(supervisor_node.SupervisorCore))
    scenario_file = write_scenario(tmp_path, edit=_short)
    out = tmp_path / 'run'
    summary = run(LaunchOptions(scenario=str(scenario_file), out=str(out), in_process=True, quiet=True,
                                wall_timeout=600.0))

    assert summary['outcome'] == c.OUTCOME_ERROR and summary['final_phase'] == c.PHASE_TERMINAL_APPROACH
    assert summary['end_reason'] == ("error: the supervisor's core raised at t = 100.000 s (flyby_supervisor: "
                                     "ZeroDivisionError: injected supervisor fault at t = 100.00 s); time_limit")
    got = read_bag(out / 'bag', topics=['/mission/events'])['/mission/events']
    (error,) = [e for e in got if e['name'] == events.NODE_ERROR]
    (idled,) = [e for e in got if e['name'] == events.PROPULSION_IDLED]
    assert error['t'] == idled['t'] == T_FAULT_S and idled['hardware_id'] == 'flyby_guidance'
    assert not [e for e in got if e['name'] == events.MANEUVER_COMMANDED and e['t'] >= T_FAULT_S]
    # The same run headless: the same outcome, reason and figures, to the bit.
    scenario = load_scenario(scenario_file)
    graph = HeadlessGraph(scenario)
    graph.supervisor.__class__ = _raising(type(graph.supervisor))
    headless = run_headless(scenario, graph).summary
    for key in ('outcome', 'end_reason', 'final_phase', 'maneuvers_executed', 'delta_v_total_mps', 'min_clearance_m'):
        assert summary[key] == headless[key], key
