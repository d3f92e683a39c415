#!/usr/bin/env python3
"""How much the person of a real depth clip moves, from the depth alone.

Prints JSON.  Reads the frames `depth_noise_stats CLIP.oni --raw FILE`
wrote (uint16 mm, 640x480, one after another) and, per frame, takes the
points nearer than --near (the person; the room is farther) and measures
two parts of their outline in 3-D with the clip's field of view: the head
(the top 0.25 m of the points) and the chest (0.3-0.55 m below the top),
each as its points' mean.  A still person's parts move by the sensor's
noise only (a few mm); this says whether the clip's person is still.  The
expressiveness of those two parts (the DPM's measure, each part a joint)
over --first.. is a lower bound of what a skeleton of this person would
score: every joint of the upper body moves with them.

    depth_noise_stats CLIP.oni --raw /tmp/clip.raw
    bench/real_clip_motion.py /tmp/clip.raw --stamps-span 1.735201
"""
import argparse
import json
import math
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))

from hri_sync.dance_off.expressiveness import (  # noqa: E402
    expressiveness)

HFOV = 1.0145          # rad, the clip's depth stream (oni_info)


def rays(width, height, hfov):
    """Per column x / z and per row y / z of the pixel centres."""
    vfov = 2 * math.atan(math.tan(hfov / 2) * height / width)
    xs = ((np.arange(width) + 0.5) / width - 0.5) * 2 * math.tan(hfov / 2)
    ys = (0.5 - (np.arange(height) + 0.5) / height) * 2 * math.tan(vfov / 2)
    return xs, ys


def parts(depth_m, xs, ys, near):
    """The head's and the chest's mean points (m), None without points."""
    mask = (depth_m > 0.3) & (depth_m < near)
    rows, cols = np.nonzero(mask)
    if not len(rows):
        return None
    z = depth_m[mask]
    pts = np.stack([xs[cols] * z, ys[rows] * z, z], axis=1)
    top = pts[:, 1].max()
    below = top - pts[:, 1]
    head, chest = pts[below <= 0.25], pts[(below >= 0.3) & (below <= 0.55)]
    if not len(head) or not len(chest):
        return None
    return head.mean(axis=0), chest.mean(axis=0), float(top)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('raw')
    ap.add_argument('--size', default='640x480')
    ap.add_argument('--stamps-span', type=float, required=True,
                    help='s from the first frame to the last (oni_info)')
    ap.add_argument('--near', type=float, default=1.5)
    ap.add_argument('--first', type=int, default=3,
                    help='first frame with the whole head in view')
    a = ap.parse_args()
    width, height = (int(v) for v in a.size.split('x'))
    frames = np.fromfile(a.raw, dtype=np.uint16).reshape(-1, height, width)
    stamps = np.linspace(0, a.stamps_span, len(frames))
    xs, ys = rays(width, height, HFOV)
    seen = [parts(f / 1000.0, xs, ys, a.near) for f in frames]
    rows = []
    for k in range(a.first, len(frames)):
        if seen[k] is None or seen[k - 1] is None:
            continue
        rows.append({'frame': k, 'top_m': round(seen[k][2], 3),
                     'head_move_m': round(float(np.linalg.norm(seen[k][0] - seen[k - 1][0])), 4),
                     'chest_move_m': round(float(np.linalg.norm(seen[k][1] - seen[k - 1][1])), 4),
                     'chest_depth_m': round(float(seen[k][1][2]), 3)})
    keep = [k for k in range(a.first, len(frames)) if seen[k] is not None]
    pos = np.array([[seen[k][0], seen[k][1]] for k in keep])
    score = expressiveness(stamps[keep], pos, duration=stamps[keep[-1]] - stamps[keep[0]])
    moves = [r['head_move_m'] for r in rows] + [r['chest_move_m'] for r in rows]
    print(json.dumps({'frames': len(frames), 'period_s': round(a.stamps_span / (len(frames) - 1), 4),
                      'per_frame': rows,
                      'move_median_m': round(float(np.median(moves)), 4),
                      'move_p95_m': round(float(np.percentile(moves, 95)), 4),
                      'head_and_chest_expressiveness': round(score.value, 3)}, indent=1))


if __name__ == '__main__':
    main()
