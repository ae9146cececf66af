"""The README as a new user meets it: every command in it names a script, option and path that exist, its scenario
table is the one scripts/scenario_table.py generates from the scenarios and their last measured runs, it quotes no
figure outside that table, points nowhere outside the repository, indexes every page of docs/, and docs/topics.md
names the contract's topics. The slow tests fly the short scenarios headless against the measured outcomes and run
the README's Python snippet on a bag of a real run."""

import contextlib
import importlib.util
import io
import json
import re
import runpy
import shlex
import subprocess
import sys

import pytest

from flyby_msgs_py import contract, frames
from flyby_testing import ROOT, run_mission

README = ROOT / 'README.md'
# The scenarios the slow test flies headless (each under a minute on this machine).
SHORT_SCENARIOS = ('paper_flyby', 'paper_flyby_6dof', 'jacobsen_optimal', 'matsunaga_tugrobot')
# A number with a unit of a measured figure (time, length, speed, mass, force, percent, factor).
FIGURE = re.compile(r'\b\d+(\.\d+)?\s?(s|min|h|m|cm|mm|m/s|mm/s|kg|g|N|N s|%|deg|x)\b')


def _load_table_script():
    spec = importlib.util.spec_from_file_location('scenario_table', ROOT / 'scripts' / 'scenario_table.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


scenario_table = _load_table_script()


def code_blocks(text, language):
    return [m.group(2) for m in re.finditer(r'^```(\w*)\n(.*?)^```', text, re.S | re.M) if m.group(1) == language]


def prose(text):
    """The README without its code blocks and without the generated table."""
    text = re.sub(r'^```.*?^```', '', text, flags=re.S | re.M)
    head, _, rest = text.partition(scenario_table.BEGIN)
    return head + rest.partition(scenario_table.END)[2]


def shell_commands():
    """Each command line of the README's sh blocks and of its inline commands (`make ...`, `.venv/bin/...`) as
    tokens, comments dropped, `nice -n N` taken off."""
    text, commands = README.read_text(), []
    inline = [' '.join(s.split()) for s in re.findall(r'`((?:make|\.venv/bin/[^\s`]+) [^`]+)`', prose(text))]
    for block in code_blocks(text, 'sh') + inline:
        for line in block.splitlines():
            tokens = shlex.split(line, comments=True)
            if tokens[:2] == ['nice', '-n']:
                tokens = tokens[3:]
            if tokens:
                commands.append(tokens)
    return commands


def makefile_targets_and_variables():
    text = (ROOT / 'Makefile').read_text()
    return (set(re.findall(r'^([\w-]+):', text, re.M)), set(re.findall(r'^(\w+)\s*\?=', text, re.M)))


def options_of(argv):
    """The long options the command's own parser accepts: its --help run in this process."""
    out, saved = io.StringIO(), sys.argv
    sys.argv = [argv[0], *argv[1:], '--help']
    try:
        with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
            if argv[0] == '-m':
                sys.argv = [argv[1], *argv[2:], '--help']
                runpy.run_module(argv[1], run_name='__main__', alter_sys=True)
            else:
                runpy.run_path(str(ROOT / argv[0]), run_name='__main__')
    finally:
        sys.argv = saved
    return set(re.findall(r'(--[\w-]+)', out.getvalue()))


def is_repository_path(token):
    return '/' in token and not token.startswith(('-', '/', 'runs/', 'tcp://', 'http')) and '<' not in token


def test_the_readme_is_under_200_lines():
    assert len(README.read_text().splitlines()) < 200


def test_the_readme_points_nowhere_outside_the_repository():
    text = README.read_text()
    assert '../' not in text
    assert 'DESIGN' not in text
    assert not re.search(r'\bissue \d+', text, re.I)
    assert not re.search(r'\bseed 00\d', text, re.I), 'cite a paper by its authors, not as "seed 00N"'


def test_the_scenario_table_in_the_readme_is_the_generated_one():
    assert scenario_table.readme_table(README.read_text()) == scenario_table.table(), \
        'stale table: run .venv/bin/python scripts/scenario_table.py --write'


def test_every_shipped_scenario_has_a_description_and_a_measured_graph_run():
    measured = scenario_table.load_measured()['scenarios']
    for path in scenario_table.scenario_files():
        entry = measured.get(path.stem, {})
        assert entry.get('shows') and entry.get('graph'), f'{path.name}: not in docs/measured/scenarios.json'
        assert {'command', 'commit', 'date', 'outcome', 'wall_s'} <= set(entry['graph'])


def test_the_measured_graph_and_headless_runs_of_a_scenario_agree():
    for name, entry in scenario_table.load_measured()['scenarios'].items():
        if 'headless' in entry:
            graph, headless = entry['graph'], entry['headless']
            assert graph['outcome'] == headless['outcome'], name
            assert graph['figures'] == pytest.approx(headless['figures'], rel=1e-9), name


def test_the_readme_quotes_no_figure_outside_the_generated_table():
    lines = [line for line in prose(README.read_text()).splitlines() if FIGURE.search(line)]
    assert not lines, f'hand-quoted figures (measure them into docs/): {lines}'


def test_every_readme_command_names_an_existing_script_option_and_path():
    targets, variables = makefile_targets_and_variables()
    helps = {}
    for tokens in shell_commands():
        if tokens[0] == 'make':
            for word in tokens[1:]:
                assert (word.split('=')[0] in variables) if '=' in word else (word in targets), tokens
            continue
        assert (ROOT / tokens[0]).exists(), f'{tokens[0]}: no such program'
        if tokens[0].endswith('/python'):
            program = tokens[1:3] if tokens[1] == '-m' else tokens[1:2]
            assert program[0] == '-m' or (ROOT / program[0]).is_file(), f'{program[0]}: no such script'
            rest = tokens[1 + len(program):]
            sub = [rest[0]] if rest and not rest[0].startswith('-') and '/' not in rest[0] else []
            key = tuple(program + sub)
            if key not in helps:
                helps[key] = options_of(list(key))
            for token in rest:
                assert not token.startswith('--') or token.split('=')[0] in helps[key], f'{token}: {tokens}'
        for token in tokens[1:]:
            assert not is_repository_path(token) or (ROOT / token).exists(), f'{token}: no such path'


def test_every_path_the_readme_names_exists():
    text = README.read_text()
    links = re.findall(r'\]\(([^)#\s]+)', text) + re.findall(r'`([\w./-]+/[\w./-]+)`', text)
    links += re.findall(r'(?<![\w/.])((?:docs|scripts|scenarios|campaigns|foxglove|test|flyby_ws)/[\w./-]*\w)', text)
    for path in links:
        if is_repository_path(path) or path.endswith('.md'):
            assert (ROOT / path).exists(), f'{path}: no such file in the repository'


def test_the_readme_indexes_every_page_of_docs():
    text = README.read_text()
    for page in sorted((ROOT / 'docs').glob('*.md')):
        assert f'docs/{page.name}' in text, f'docs/{page.name} is not in the README index'


def test_the_readme_python_snippets_compile():
    for block in code_blocks(README.read_text(), 'python'):
        compile(block, 'README.md', 'exec')


def test_docs_topics_names_every_contract_topic_and_service_with_its_type():
    rows = re.findall(r'^\| `(/[\w/]+)` \| ([\w/]+) \|', (ROOT / 'docs' / 'topics.md').read_text(), re.M)
    services = {getattr(contract, n) for n in dir(contract) if n.endswith('_SERVICE')}
    expected = {contract.absolute(t): k.replace('/msg/', '/') for t, k in contract.TOPIC_TYPES.items()}
    expected.update({contract.absolute(s): 'std_srvs/Trigger' for s in services})
    expected.update({tf: frames.TF_TYPE.replace('/msg/', '/') for tf in (frames.TF_TOPIC, frames.TF_STATIC_TOPIC)})
    assert dict(rows) == expected


def test_the_table_script_refuses_an_unknown_scenario_in_one_line():
    done = subprocess.run([sys.executable, 'scripts/scenario_table.py', '--measure', '--only', 'nope'], cwd=ROOT,
                          capture_output=True, text=True)
    assert done.returncode == 2
    assert done.stderr.strip().count('\n') == 0 and "'nope'" in done.stderr and '--only' in done.stderr


def test_the_table_script_refuses_measure_options_without_measure():
    done = subprocess.run([sys.executable, 'scripts/scenario_table.py', '--headless-only'], cwd=ROOT,
                          capture_output=True, text=True)
    assert done.returncode == 2 and '--measure' in done.stderr and 'Traceback' not in done.stderr


def test_the_table_script_refuses_a_readme_without_markers(tmp_path, monkeypatch):
    monkeypatch.setattr(scenario_table, 'README', tmp_path / 'README.md')
    scenario_table.README.write_text('# no table here\n')
    with pytest.raises(SystemExit, match='markers'):
        scenario_table.write_readme()


def test_the_table_script_writes_the_table_between_the_markers(tmp_path, monkeypatch):
    monkeypatch.setattr(scenario_table, 'README', tmp_path / 'README.md')
    scenario_table.README.write_text(f'before\n{scenario_table.BEGIN}\nold\n{scenario_table.END}\nafter\n')
    scenario_table.write_readme()
    text = scenario_table.README.read_text()
    assert text.startswith('before\n') and text.endswith('after\n')
    assert scenario_table.readme_table(text) == scenario_table.table()


@pytest.mark.slow
@pytest.mark.parametrize('name', SHORT_SCENARIOS)
def test_a_short_scenario_flown_headless_gives_its_measured_outcome_and_figures(name):
    from flyby_mission.headless import run_headless
    from flyby_sim.scenario import load_scenario

    measured = scenario_table.load_measured()['scenarios'][name]['headless']
    summary = run_headless(load_scenario(ROOT / 'scenarios' / f'{name}.yaml')).summary
    assert summary['outcome'] == measured['outcome']
    figures = {k: summary[k] for k in measured['figures'] if k != 'chasers'}
    assert figures == pytest.approx({k: v for k, v in measured['figures'].items() if k != 'chasers'}, rel=1e-6)


@pytest.mark.slow
def test_the_readme_rosbags_snippet_reads_the_bag_of_a_real_run(tmp_path):
    run = tmp_path / 'run'
    done = run_mission('--scenario', ROOT / 'scenarios' / 'paper_flyby.yaml', '--out', run)
    assert done.returncode == 0, done.stderr[-3000:]
    [snippet] = [b for b in code_blocks(README.read_text(), 'python') if 'AnyReader' in b]
    bag_path = re.search(r"Path\('([^']+)'\)", snippet).group(1)
    script = tmp_path / 'snippet.py'
    script.write_text(snippet.replace(bag_path, str(run / 'bag')))
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, check=True, timeout=120)
    rows = [line.split() for line in done.stdout.splitlines()]
    assert len(rows) > 100 and all(len(r) == 4 for r in rows)
    sim_time_s = json.loads((run / 'summary.json').read_text())['sim_time_s']
    assert float(rows[-1][0]) == pytest.approx(sim_time_s, abs=1.0)
