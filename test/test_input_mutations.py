"""Issue 37's acceptance harness (scripts/bench/input_mutations.py) on a small deterministic sample of leaves: a
regression in the loaders' refusals (a hang, a traceback, a refusal that names neither the file nor the key, a
meaningless value accepted) fails here in seconds; the whole run and its counts are docs/hardening.md's."""

import importlib.util
import random
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_SPEC = importlib.util.spec_from_file_location('input_mutations', ROOT / 'scripts' / 'bench' / 'input_mutations.py')
harness = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(harness)


def test_a_sample_of_mutants_has_no_hang_traceback_unnamed_refusal_or_meaningless_acceptance(tmp_path):
    rng = random.Random(37)
    cases = list(harness.scenario_cases(ROOT / 'scenarios' / 'paper_flyby.yaml', 10.0, 2, rng))
    cases += list(harness.scenario_cases(ROOT / 'scenarios' / 'jacobsen_two_robots.yaml', 10.0, 1, rng))
    cases += list(harness.campaign_case_list(ROOT / 'campaigns' / 'smoke.yaml', 10.0, 1, rng))
    results = harness.load_all(cases, 1, tmp_path)
    bad = [r for r in results if r['class'] in harness.BAD]
    assert not bad, harness.table(results)
    refused = sum(r['class'] == 'refused' for r in results)
    assert refused > 0.8 * len(results) and {r['mutation'] for r in results} >= {'nan', 'typo', 'physical'}


def test_the_harness_counts_a_refusal_of_another_key_or_file_as_unnamed_and_nan_accepted_as_meaningless():
    case = {'kind': 'scenario', 'path': ['chaser', 'mass_kg'], 'mutation': 'nan'}
    assert harness.named(case, 'f.yaml', 'chaser.mass_kg', 'f.yaml: chaser.mass_kg: must be finite, got nan')
    assert not harness.named(case, 'f.yaml', 'orbit.radius_m', 'f.yaml: orbit.radius_m: must be > 0')
    assert not harness.named(case, 'f.yaml', 'chaser.mass_kg', 'g.yaml: chaser.mass_kg: must be finite, got nan')
    assert harness._accepted_class(case) == 'meaningless'
    assert harness._accepted_class({**case, 'mutation': 'negative', 'path': ['chaser', 'initial_position_hill_m']}) \
        == 'accepted'
