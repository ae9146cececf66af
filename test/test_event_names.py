"""Event names are declared once, in flyby_msgs_py.events (DESIGN §11): no core emits or matches an event by a
string literal. Read from the source tree: the name argument of an event (a call or a tuple whose level is a
constant, e.g. ``Event(t, 'OK', NAME, ...)``, ``('WARN', NAME, ...)``) and a comparison with an event's name."""

import ast

import pytest

from flyby_msgs_py import events
from flyby_testing import ROOT

SRC = ROOT / 'flyby_ws' / 'src'
LEVELS = {'OK', 'WARN', 'ERROR', 'STALE'}
EVENTS_MODULE = SRC / 'flyby_msgs_py' / 'flyby_msgs_py' / 'events.py'


def _sources():
    yield from (p for p in sorted(SRC.rglob('*.py')) if '/test/' not in str(p) and p != EVENTS_MODULE)
    yield from sorted((ROOT / 'scripts').rglob('*.py'))


def _is_level(node):
    return isinstance(node, ast.Constant) and node.value in LEVELS


def _literal_names(tree):
    """(line, text) of every string literal that stands for an event's name."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            args = node.args
            for i in range(len(args) - 1):
                if _is_level(args[i]) and isinstance(args[i + 1], ast.Constant) and isinstance(args[i + 1].value, str):
                    yield node.lineno, args[i + 1].value
        elif isinstance(node, ast.Tuple) and len(node.elts) >= 2 and _is_level(node.elts[0]):
            second = node.elts[1]
            if isinstance(second, ast.Constant) and isinstance(second.value, str):
                yield node.lineno, second.value
        elif isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any(_names_an_event(s) for s in sides):
                for s in sides:
                    for const in ([s] if isinstance(s, ast.Constant) else getattr(s, 'elts', [])):
                        if isinstance(const, ast.Constant) and const.value in events.ALL:
                            yield node.lineno, const.value


def _names_an_event(node):
    """``x.name``, ``x['name']`` or a variable called ``name``."""
    if isinstance(node, ast.Attribute):
        return node.attr == 'name'
    if isinstance(node, ast.Subscript):
        return isinstance(node.slice, ast.Constant) and node.slice.value == 'name'
    return isinstance(node, ast.Name) and node.id == 'name'


def test_the_events_module_declares_each_name_once():
    values = [v for k, v in vars(events).items() if k.isupper() and k != 'ALL']
    assert len(values) == len(set(values)) == len(events.ALL) > 40


@pytest.mark.parametrize('path', list(_sources()), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_event_name_string_outside_the_events_module(path):
    found = sorted(set(_literal_names(ast.parse(path.read_text(), filename=str(path)))))
    assert found == [], f'{path.relative_to(ROOT)}: event names as literals (use flyby_msgs_py.events): {found}'
