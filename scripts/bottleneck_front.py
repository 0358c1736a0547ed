#!/usr/bin/env python3
"""Density and speed in front of the door of the bottleneck study, from its trajectories.

usage: python3 scripts/bottleneck_front.py [OUT]     (default out/bottleneck)

Reads the results table of `sweep batch examples/plans/bottleneck.toml` (OUT/results.csv) and,
for each trial with a flow, its `trajectory.csv` and `summary.json`. Over the window of the
table's `flow` (from the exit of the first 20 % of the people to that of the first 80 %), it
measures in the area in front of the door, 1 m deep and as wide as the door
(x in [9, 10], y in [4 - w/2, 4 + w/2]):

* rho: the people whose centre is in the area, per m², averaged over the frames;
* v: their mean velocity towards the door (along x), each from its position at this frame and
  at the next (frames 0.1 s apart);
* rho * v: the specific flow through the area these give (people/(m·s)), beside the table's
  flow / width.

Prints one line per trial and the means over the seeds per width. Standard library only.
"""
import csv
import json
import math
import os
import statistics
import sys

DEPTH = 1.0
DOOR_X = 10.0
DOOR_Y = 4.0
FROM, TO = 0.2, 0.8


def window(summary):
    """The times of the exits of the first 20 % and the first 80 % of the people."""
    n = summary["people"]
    k1 = max(1, math.ceil(FROM * n))
    k2 = math.floor(TO * n)

    def time_of(k):
        return next((t for t, out in summary["people_out"] if out >= k), None)

    return time_of(k1), time_of(k2)


def front(trial_dir, width):
    with open(os.path.join(trial_dir, "summary.json")) as f:
        t1, t2 = window(json.load(f))
    frames = {}
    with open(os.path.join(trial_dir, "trajectory.csv"), newline="") as f:
        for row in csv.DictReader(f):
            t = float(row["t"])
            # The frame after the window gives the last frame's velocities.
            if t1 - 1e-9 <= t <= t2 + 0.2:
                frames.setdefault(t, {})[row["id"]] = (float(row["x"]), float(row["y"]))
    times = sorted(frames)
    area = DEPTH * width
    lo, hi = DOOR_Y - width / 2, DOOR_Y + width / 2
    counts, speeds = [], []
    for t, t_next in zip(times, times[1:]):
        if t > t2 + 1e-9:
            break
        inside = [
            (i, x)
            for i, (x, y) in frames[t].items()
            if DOOR_X - DEPTH <= x <= DOOR_X and lo <= y <= hi
        ]
        counts.append(len(inside))
        dt = t_next - t
        for i, x in inside:
            # Who left between the two frames is written no more: their last step is not seen.
            if i in frames[t_next]:
                speeds.append((frames[t_next][i][0] - x) / dt)
    rho = statistics.mean(counts) / area
    v = statistics.mean(speeds)
    return rho, v


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join("out", "bottleneck")
    with open(os.path.join(out, "results.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    by_width = {}
    print("width  seed  flow/w  rho    v     rho*v")
    for row in rows:
        if not row["flow"]:
            continue
        w = float(row["door_width"])
        rho, v = front(os.path.join(out, row["dir"]), w)
        specific = float(row["flow"]) / w
        print(f"{w:5.1f}  {row['seed']:>4}  {specific:6.2f}  {rho:5.2f}  {v:5.2f}  {rho * v:5.2f}")
        by_width.setdefault(w, []).append((specific, rho, v, rho * v))
    print("\nmeans over the seeds")
    print("width  trials  flow/w  rho    v     rho*v")
    for w, values in sorted(by_width.items()):
        m = [statistics.mean(c) for c in zip(*values)]
        print(f"{w:5.1f}  {len(values):6}  {m[0]:6.2f}  {m[1]:5.2f}  {m[2]:5.2f}  {m[3]:5.2f}")


if __name__ == "__main__":
    main()
