"""Writing the figures of a run directory: the tables of each mission kind (the catalogue: flyby_mission.report), each
figure drawn on its own so that one whose data is missing is skipped and one that fails costs no other."""

import traceback
from pathlib import Path

from flyby_mission.report import faults, flyby, post_capture, rigid_body, sync
from flyby_mission.report.loading import FleetRun, Run, Skipped, say
from flyby_mission.report.plotting import plt
from flyby_mission.report.two_robots import fig_chasers
from flyby_msgs_py.schema import ScenarioError
from flyby_sim.scenario import load_scenario


def write_fleet(run_dir, out, scenario):
    """The figure of several chasers: ([path] or [], [] or its name if it failed)."""
    path = out / 'chasers.png'
    try:
        fig_chasers(FleetRun(run_dir, scenario), path)
        return [path], []
    except Skipped as why:
        say(f'chasers.png skipped: {why}')
        return [], []
    except Exception:  # noqa: BLE001 - reported like any figure's failure
        say(f'chasers.png failed:\n{traceback.format_exc()}')
        return [], ['chasers.png']
    finally:
        plt.close('all')


def write_figures(run_dir, out_dir):
    """(paths written, names of the figures that failed)."""
    out = Path(out_dir) if out_dir is not None else Path(run_dir)
    out.mkdir(parents=True, exist_ok=True)
    try:
        scenario = load_scenario(Path(run_dir) / 'scenario.yaml')
    except (OSError, ScenarioError):
        scenario = None  # Run says so
    if scenario is not None and scenario.chaser_names:
        return write_fleet(run_dir, out, scenario)
    run = Run(run_dir)
    written, failed = [], []
    for name, draw in (flyby.FIGURES + (rigid_body.FIGURES if run.rigid_body else ())
                       + (sync.FIGURES if run.sync else ()) + (post_capture.FIGURES if run.post_capture else ())
                       + (post_capture.TRANSPORT_FIGURES if run.transport else ())
                       + (faults.FIGURES if faults.has_faults(run.events) else ())):
        path = out / name
        try:
            draw(run, path)
            written.append(path)
        except Skipped as why:
            say(f'{name} skipped: {why}')
        except Exception:  # noqa: BLE001 - one broken figure must not cost the others
            say(f'{name} failed:\n{traceback.format_exc()}')
            failed.append(name)
        finally:
            plt.close('all')
    return written, failed


def write_report(run_dir, out_dir=None):
    """Write the figures of the run in run_dir into out_dir (default run_dir); the paths written.

    A figure whose data is missing is skipped, one that fails is reported; both on stderr.
    """
    return write_figures(run_dir, out_dir)[0]
