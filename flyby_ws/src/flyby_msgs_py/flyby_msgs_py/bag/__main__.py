"""Command line: ``python -m flyby_msgs_py.bag info DIR`` / ``repair DIR``.

``info`` checks the CRCs (``integrity.verify_bag``), then prints topics, types, counts and the time
range; ``repair`` rebuilds a bag whose recorder
was killed (``repair.repair_bag``). Exit code 0 on success, 1 on a bag or file error (message on
stderr).
"""

import argparse
import sys

from flyby_msgs_py.bag.common import BagError
from flyby_msgs_py.bag.integrity import verify_bag
from flyby_msgs_py.bag.reader import bag_time_range, bag_topics
from flyby_msgs_py.bag.repair import repair_bag


def _info(bag_dir):
    checked = verify_bag(bag_dir)
    topics = bag_topics(bag_dir)
    span = bag_time_range(bag_dir)
    width = max([len(t) for t in topics] + [5])
    lines = [f'bag: {bag_dir}']
    if span is None:
        lines.append('time range: (no messages)')
    else:
        lines.append(f'time range: {span[0] * 1e-9:.3f} s .. {span[1] * 1e-9:.3f} s '
                     f'({(span[1] - span[0]) * 1e-9:.3f} s)')
    lines.append(f'messages: {sum(n for _, n in topics.values())}')
    lines.append(f'CRCs: {checked} chunks checked' if checked else 'CRCs: none written (bag not checked)')
    lines.append(f'{"topic":<{width}}  {"count":>8}  type')
    for topic, (type_name, count) in sorted(topics.items()):
        lines.append(f'{topic:<{width}}  {count:>8}  {type_name}')
    return '\n'.join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(prog='python -m flyby_msgs_py.bag',
                                     description='Inspect or repair a flyby rosbag2 (MCAP) bag.')
    sub = parser.add_subparsers(dest='command', required=True)
    sub.add_parser('info', help='topics, types, counts, time range').add_argument('bag_dir')
    sub.add_parser('repair', help='rebuild a bag whose recorder was killed').add_argument('bag_dir')
    args = parser.parse_args(argv)
    try:
        if args.command == 'info':
            print(_info(args.bag_dir))
        else:
            report = repair_bag(args.bag_dir)
            if report['repaired']:
                print(f'{args.bag_dir}: damaged: {report["damage"]}')
                print(f'{args.bag_dir}: repaired, {report["message_count"]} messages salvaged '
                      f'({report["bytes_salvaged"]} of {report["bytes_total"]} bytes; '
                      f'stopped at: {report["stop_reason"]}); original kept as '
                      f'{report["damaged_file"]}')
                last = report['last_timestamp_ns']
                if last is not None:
                    print(f'last message at {last * 1e-9:.3f} s')
                for topic, n in sorted(report['messages'].items()):
                    print(f'  {topic}: {n}')
            else:
                print(f'{args.bag_dir}: bag is valid, nothing to repair')
    except (BagError, OSError) as err:
        print(f'flyby_msgs_py.bag: error: {err}', file=sys.stderr)
        return 1
    return 0


if __name__ == '__main__':
    sys.exit(main())
