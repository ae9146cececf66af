"""A run directory that replays its run (DESIGN §11): its ``scenario.yaml`` is the scenario flown, the
input's text with the effective seed (``--seed`` overrides the file's), and its ``run.json`` holds under ``replay``
the command that flies it again from there (scripts/run_mission.py's or scripts/closed_loop.py's).

The seed is the one scenario value a command line overrides; the launcher's other options that change what is flown
(``--without``, ``--abort-at``, ``--kill``) are not the scenario's and go into the replay command instead.
"""

import shlex
from pathlib import Path

import yaml

SEED_KEY = 'seed'
SCENARIO_FILE = 'scenario.yaml'
REPLAY_KEY = 'replay'  # run.json's key of the replay command
PYTHON = '.venv/bin/python'  # the commands run from the repository's root, as the README's do


def _seed_value_span(text):
    """(start, end) character offsets of the top-level ``seed`` value in the YAML text, by the YAML composer's marks;
    None when the document is not a mapping holding a plain ``seed`` scalar."""
    root = yaml.compose(text, Loader=yaml.SafeLoader)
    if not isinstance(root, yaml.MappingNode):
        return None
    for key, value in root.value:
        if isinstance(key, yaml.ScalarNode) and key.value == SEED_KEY and isinstance(value, yaml.ScalarNode):
            return value.start_mark.index, value.end_mark.index
    return None


def scenario_text(path, seed):
    """The scenario file at ``path`` as the run flew it with ``seed``: its own text, comments and order kept, with
    only the top-level seed's value replaced (unchanged when it is already ``seed``). A document whose seed the
    composer cannot place (a flow mapping, no seed) is dumped whole with the seed set, its comments lost; either way
    the text loads to the file's mapping with ``seed`` set."""
    text = Path(path).read_text()
    data = yaml.safe_load(text)
    if isinstance(data, dict) and data.get(SEED_KEY) == seed:
        return text
    wanted = {**data, SEED_KEY: seed}
    span = _seed_value_span(text)
    if span is not None:
        edited = f'{text[:span[0]]}{seed}{text[span[1]:]}'
        if yaml.safe_load(edited) == wanted:
            return edited
    return yaml.safe_dump(wanted, sort_keys=False)


def write_scenario(run_dir, path, seed):
    """Write ``run_dir/scenario.yaml`` (``scenario_text``); its path."""
    out = Path(run_dir) / SCENARIO_FILE
    out.write_text(scenario_text(path, seed))
    return out


def replay_command(script, run_dir, options=()):
    """The command line (text) that flies the run of ``run_dir`` again: ``scripts/<script>`` on the run's
    scenario.yaml into ``<run_dir>-replay``, with ``options`` (the command's own, those that change the flight)."""
    run_dir = Path(run_dir).absolute()
    return shlex.join([PYTHON, f'scripts/{script}', '--scenario', str(run_dir / SCENARIO_FILE),
                       '--out', f'{run_dir}-replay', *map(str, options)])


def launcher_options(options):
    """The options of scripts/run_mission.py (a launcher.LaunchOptions) that change what is flown or how, as command
    line arguments: --in-process, --rtf, --without, --abort-at, --kill."""
    args = ['--in-process'] if options.in_process else []
    if options.rtf:
        args += ['--rtf', options.rtf]
    for name in options.without:
        args += ['--without', name]
    if options.abort_at is not None:
        args += ['--abort-at', options.abort_at]
    if options.kill:
        args += ['--kill', options.kill]
    return args
