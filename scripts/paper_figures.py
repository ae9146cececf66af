#!/usr/bin/env python3
"""Regenerate seed 000 Fig. 6-8 (sections 3.2-3.3) from flyby_planner.flyby.families.

    paper_figures.py [--out docs/figures]

Writes seed000_fig6_inplane_xz.png, seed000_fig7_inplane_region.png and
seed000_fig8_outofplane.png, and prints the Markdown table of docs/relative_motion.md.
"""

import argparse
from pathlib import Path

from flyby_mission.report.families import fig6_inplane_xz, fig_region, markdown_table
from flyby_planner.flyby.families import seed000_family, time_grid
from flyby_sim.dynamics.orbital import mean_motion_rad_s

ROOT = Path(__file__).resolve().parents[1]
RADIUS_M = 7.0e6  # seed 000 section 5
T_MAX_S = 300.0  # planner.flyby_duration_s of scenarios/paper_flyby.yaml


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--out', type=Path, default=ROOT / 'docs' / 'figures', help='output directory')
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    n = mean_motion_rad_s(RADIUS_M)
    t_s = time_grid(T_MAX_S)
    families = {case: seed000_family(case, n, t_s)[0] for case in ('in_plane', 'out_of_plane')}
    fig6_inplane_xz(families['in_plane'], args.out / 'seed000_fig6_inplane_xz.png')
    fig_region(families['in_plane'], 2, (2.0, -8.0), 'Fig. 7, spin +z',
               args.out / 'seed000_fig7_inplane_region.png')
    fig_region(families['out_of_plane'], 1, (-1.3, -1.6), 'Fig. 8, spin +y',
               args.out / 'seed000_fig8_outofplane.png')
    print(markdown_table(families))


if __name__ == '__main__':
    main()
