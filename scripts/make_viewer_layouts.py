#!/usr/bin/env python3
"""Write the Foxglove and PlotJuggler layouts of a session's MCAP.

    scripts/make_viewer_layouts.py [--clients a,b,c] [--participants a,b]
                                   [--out config/layouts]

writes OUT/hri_sync.foxglove.json and OUT/hri_sync.plotjuggler.xml
(hri_sync.tools.layouts): clock offsets and uncertainty of --clients,
first-frame offset, timing bound and scores of --participants (in the
decision's order), all against header stamps. The defaults are the
dance-off's, the layouts shipped in config/layouts. `report --export mcap`
writes a pair for each bag's own clients beside its MCAP (docs/viewers.md).
"""
import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))

from hri_sync.tools import layouts  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--clients', default=','.join(layouts.CLOCKS))
    parser.add_argument('--participants',
                        default=','.join(layouts.PARTICIPANTS))
    parser.add_argument('--out', default=os.path.join(ROOT, 'config',
                                                      'layouts'))
    args = parser.parse_args()
    spec = layouts.plots([c for c in args.clients.split(',') if c],
                         [p for p in args.participants.split(',') if p])
    os.makedirs(args.out, exist_ok=True)
    for name, text in (('hri_sync.foxglove.json', layouts.foxglove(spec)),
                       ('hri_sync.plotjuggler.xml',
                        layouts.plotjuggler(spec))):
        path = os.path.join(args.out, name)
        with open(path, 'w') as f:
            f.write(text)
        print(path)


if __name__ == '__main__':
    main()
