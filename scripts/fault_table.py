#!/usr/bin/env python3
"""Write flyby_mission/fault_table.yaml from the FMECA table in docs/faults.md (docs/faults.md).

    .venv/bin/python scripts/fault_table.py            # write it
    .venv/bin/python scripts/fault_table.py --check    # exit 1 where it differs from the FMECA
"""

import argparse
import sys
from pathlib import Path

import yaml

from flyby_mission.fault_table import TABLE_PATH, fmeca_rows

REPO = Path(__file__).resolve().parents[1]

HEADER = '# Generated from the FMECA in docs/faults.md by scripts/fault_table.py: edit the FMECA, not this file.\n'


def table_text(markdown):
    """The YAML text of the FMECA's rows."""
    return HEADER + yaml.safe_dump({'faults': fmeca_rows(markdown)}, sort_keys=False, width=120)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--check', action='store_true', help='exit 1 where the YAML differs from the FMECA')
    args = parser.parse_args(argv)
    try:
        text = table_text((REPO / 'docs' / 'faults.md').read_text())
    except ValueError as err:
        print(f'docs/faults.md: {err}', file=sys.stderr)
        return 2
    if args.check:
        same = TABLE_PATH.exists() and TABLE_PATH.read_text() == text
        print(f'{TABLE_PATH.relative_to(REPO)}: {"up to date" if same else "differs from docs/faults.md"}')
        return 0 if same else 1
    TABLE_PATH.write_text(text)
    print(f'wrote {TABLE_PATH.relative_to(REPO)}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
