#!/usr/bin/env python3
"""An independent check of a `sweep run` output, written apart from the Rust code.

usage: python3 scripts/check_trajectory.py SCENE.toml OUTDIR [--tol 1e-9]

Reads the scene file (room, exits and obstacles, from WKT too, their motion, an arena's round
wall, people, crowds, sources) and the
run's `trajectory.csv`, `people.csv` and `summary.json`, and recomputes at every recorded
frame: overlaps of people, penetrations of walls and obstacles (of obstacles on a path also at
each waypoint between two frames, against both frames' positions), people written outside the
room (the trajectory writes only people present: their disk not wholly outside), non-finite
numbers, people who came back after leaving (written again after a frame without them), the
largest speed between frames; compares who is missing from each frame with the departures of
`people.csv` (each one wholly outside the room); a run that ends with everybody gone
between two frames ends on an empty frame, which has no rows: it is taken at the summary's
`t_final` when `people.csv` says everybody left by then; then compares the summary's counts,
times and largest overlap and penetration with what the trajectory shows. Standard library only
(Python 3.11 or later, for tomllib).

People are numbered as `sweep run` numbers them: the `[[people]]` first, then each crowd in
order, then each source's. A source's people may be missing from the frames before their first,
but not be written before they are due. Radii are read from `people.csv` and checked against
the scene's: a number, or the range a crowd's or a source's radii are drawn from, plus half of
its `gap` (the disk its people keep clear).

Prints what it found; exits with 1 when a flag is raised (anything beyond `--tol`, or a
summary that disagrees with the trajectory), 0 otherwise.
"""
import argparse
import csv
import json
import math
import os
import re
import sys
import tomllib
from collections import defaultdict

parser = argparse.ArgumentParser(description="An independent check of a `sweep run` output.")
parser.add_argument("scene", help="the scene file the run was made from")
parser.add_argument("out", help="the run's output directory")
parser.add_argument("--tol", type=float, default=1e-9,
                    help="largest overlap or penetration accepted (default 1e-9)")
arguments = parser.parse_args()
TOL = arguments.tol
scene_path, out = arguments.scene, arguments.out
with open(scene_path, "rb") as scene_file:
    sc = tomllib.load(scene_file)

# ---------- geometry
def wkt_rings(text):
    """The rings (or line strings) of a WKT geometry, in order, as lists of points; a ring's
    closing point (a repeat of its first) dropped. Polygons' rings are grouped by polygon."""
    text = text.strip()
    kind = re.match(r'[A-Za-z]+', text).group(0).upper()
    body = text[len(kind):].strip()

    def points(chunk):
        pts = [tuple(float(v) for v in pair.split()) for pair in chunk.split(',')]
        if len(pts) > 1 and pts[0] == pts[-1]:
            pts = pts[:-1]
        return pts

    if kind in ('LINESTRING', 'POLYGON'):
        parts = [re.findall(r'\(([^()]*)\)', body)]
    else:  # MULTILINESTRING, MULTIPOLYGON: one group per part
        parts = ([re.findall(r'\(([^()]*)\)', g) for g in re.findall(r'\(\s*(\([^()]*\)(?:\s*,\s*\([^()]*\))*)\s*\)', body)]
                 if kind == 'MULTIPOLYGON' else [[c] for c in re.findall(r'\(([^()]*)\)', body)])
    return kind, [[points(c) for c in group] for group in parts]


room = sc['room']
wkt_holes = []
if 'rectangle' in room:
    x0, y0, x1, y1 = room['rectangle']
    poly = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
elif 'polygon' in room:
    poly = [tuple(p) for p in room['polygon']]
else:
    text = room.get('wkt')
    if text is None:
        with open(os.path.join(os.path.dirname(scene_path), room['wkt_file'])) as wkt_file:
            text = wkt_file.read()
    _, polygons = wkt_rings(text)
    poly, wkt_holes = polygons[0][0], polygons[0][1:]
exits = [(tuple(e['from']), tuple(e['to'])) for e in sc.get('exits', [])]
if 'exits_wkt' in room:
    exits += [(line[0], line[1]) for group in wkt_rings(room['exits_wkt'])[1] for line in group]


def seg_dist(p, a, b):
    ax, ay = a; bx, by = b; px, py = p
    dx, dy = bx - ax, by - ay
    L2 = dx * dx + dy * dy
    if L2 == 0:
        return math.hypot(px - ax, py - ay)
    t = ((px - ax) * dx + (py - ay) * dy) / L2
    t = max(0.0, min(1.0, t))
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


def on_segment_param(p, a, b):
    dx, dy = b[0] - a[0], b[1] - a[1]
    L2 = dx * dx + dy * dy
    return ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / L2


def collinear(a, b, c, eps=1e-12):
    return abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) <= eps * max(1, abs(b[0]) + abs(b[1]) + abs(c[0]) + abs(c[1]))


# walls = room edges minus exits
walls = []
n = len(poly)
for i in range(n):
    a, b = poly[i], poly[(i + 1) % n]
    L2 = (b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2
    if L2 == 0:
        continue
    cuts = []
    for (e0, e1) in exits:
        if collinear(a, b, e0) and collinear(a, b, e1):
            t0, t1 = sorted((on_segment_param(e0, a, b), on_segment_param(e1, a, b)))
            t0, t1 = max(0, t0), min(1, t1)
            if t1 > t0:
                cuts.append((t0, t1))
    cuts.sort()
    cur = 0.0
    pieces = []
    for (t0, t1) in cuts:
        if t0 > cur:
            pieces.append((cur, t0))
        cur = max(cur, t1)
    if cur < 1:
        pieces.append((cur, 1.0))
    for (t0, t1) in pieces:
        walls.append(((a[0] + t0 * (b[0] - a[0]), a[1] + t0 * (b[1] - a[1])),
                      (a[0] + t1 * (b[0] - a[0]), a[1] + t1 * (b[1] - a[1]))))


def inside_poly(p, P):
    x, y = p
    c = False
    m = len(P)
    for i in range(m):
        ax, ay = P[i]; bx, by = P[(i + 1) % m]
        if (ay > y) != (by > y):
            xi = ax + (y - ay) * (bx - ax) / (by - ay)
            if x < xi:
                c = not c
    return c


def dist_to_boundary(p, P):
    return min(seg_dist(p, P[i], P[(i + 1) % len(P)]) for i in range(len(P)))


obstacles = []  # (kind, data, motion)
for o in sc.get('obstacles', []):
    mot = None
    if 'velocity' in o:
        mot = ('vel', o['velocity'])
    elif 'path' in o:
        mot = ('path', o['path'])
    if 'disk' in o:
        obstacles.append(('disk', (tuple(o['disk']['center']), o['disk']['radius']), mot))
    elif 'segment' in o:
        obstacles.append(('seg', (tuple(o['segment']['from']), tuple(o['segment']['to'])), mot))
    elif 'polygon' in o:
        obstacles.append(('poly', [tuple(p) for p in o['polygon']], mot))
# A WKT room's holes, then `obstacles_wkt`'s polygons, numbered after the [[obstacles]].
obstacles += [('poly', hole, None) for hole in wkt_holes]
if 'obstacles_wkt' in room:
    obstacles += [('poly', group[0], None) for group in wkt_rings(room['obstacles_wkt'])[1]]
arena = sc.get('arena')


def offset(mot, t):
    if mot is None:
        return (0.0, 0.0)
    if mot[0] == 'vel':
        return (t * mot[1][0], t * mot[1][1])
    path = mot[1]
    if t <= path[0][0]:
        return (path[0][1], path[0][2])
    for i in range(len(path) - 1):
        t0, a0, b0 = path[i]; t1, a1, b1 = path[i + 1]
        if t0 <= t <= t1:
            s = (t - t0) / (t1 - t0) if t1 > t0 else 1
            return (a0 + s * (a1 - a0), b0 + s * (b1 - b0))
    return (path[-1][1], path[-1][2])


def obstacle_gap(p, r, ob, t):
    kind, d, mot = ob
    ox, oy = offset(mot, t)
    q = (p[0] - ox, p[1] - oy)
    if kind == 'disk':
        return math.hypot(q[0] - d[0][0], q[1] - d[0][1]) - d[1] - r
    if kind == 'seg':
        return seg_dist(q, d[0], d[1]) - r
    g = dist_to_boundary(q, d)
    if inside_poly(q, d):
        return -g - r
    return g - r


# ---------- people radii, speeds and arrivals
def radius_range(spec, gap):
    """[lo, hi] a radius spec allows, with half the group's gap added (the constraints' disk,
    which people.csv lists)."""
    if isinstance(spec, (int, float)):
        lo, hi = spec, spec
    elif isinstance(spec, list):
        lo, hi = spec
    elif 'uniform' in spec:
        lo, hi = spec['uniform']
    else:
        lo, hi = spec.get('within', [0.0, math.inf])
    return (lo + gap / 2, hi + gap / 2)


def top_speed(spec):
    """The largest desired speed a speed spec allows (for the report only)."""
    if spec is None:
        return 1.0
    if isinstance(spec, (int, float)):
        return spec
    if 'uniform' in spec:
        return spec['uniform'][1]
    return spec.get('within', [0.0, math.inf])[1]


def arrival_times(src):
    """When each person of a [[sources]] entry is due, at the earliest."""
    if 'times' in src:
        counts = src.get('counts', [1] * len(src['times']))
        return [t for t, k in zip(src['times'], counts) for _ in range(k)]
    start = src.get('start', 0.0)
    return [start + k / src['rate'] for k in range(src['count'])]


# Who is in the scene, numbered as `sweep run` numbers them: [[people]], [[crowds]], then
# [[sources]]; due[i] is when person i may first be written (0 for everybody there at t = 0).
scene_radii, speeds, due = [], [], []
for p in sc.get('people', []):
    scene_radii.append(radius_range(p['radius'], 0.0)); speeds.append(top_speed(p.get('speed')))
    due.append(0.0)
for c in sc.get('crowds', []):
    scene_radii.extend([radius_range(c['radius'], c.get('gap', 0.0))] * c['count'])
    speeds.extend([top_speed(c.get('speed'))] * c['count'])
    due.extend([0.0] * c['count'])
for src in sc.get('sources', []):
    times_due = arrival_times(src)
    scene_radii.extend([radius_range(src['radius'], src.get('gap', 0.0))] * len(times_due))
    speeds.extend([top_speed(src.get('speed'))] * len(times_due))
    due.extend(times_due)
N = len(scene_radii)
flags = []
radii, departures = [], []
with open(os.path.join(out, 'people.csv')) as f:
    rd = csv.reader(f)
    hdr = next(rd)
    assert hdr == ['id', 'radius', 't_left', 'x_left', 'y_left'], hdr
    for k, (i, r, tl, xl, yl) in enumerate(rd):
        assert int(i) == k, (i, k)
        radii.append(float(r))
        departures.append((float(tl), float(xl), float(yl)) if tl else None)
if len(radii) != N:
    print(f'people.csv lists {len(radii)} people, the scene {N}'); flags.append('PEOPLE_COUNT')
    radii = (radii + [max(radii or [0.0])] * N)[:N]
    departures = (departures + [None] * N)[:N]
for i, (r, (lo, hi)) in enumerate(zip(radii, scene_radii)):
    if not (lo - 1e-12 <= r <= hi + 1e-12):
        print(f'person {i}: radius {r} in people.csv, the scene gives [{lo}, {hi}]')
        flags.append('RADIUS'); break
for i, d in enumerate(departures):
    if d is not None:
        _, xl, yl = d
        if inside_poly((xl, yl), poly) or dist_to_boundary((xl, yl), poly) < radii[i] - 1e-9:
            print(f'person {i} left at ({xl}, {yl}), where their disk is not wholly outside the room')
            flags.append('LEFT_INSIDE'); break

# ---------- read trajectory
rows = defaultdict(dict)
bad = []
ids = set()
with open(os.path.join(out, 'trajectory.csv')) as f:
    rd = csv.reader(f)
    hdr = next(rd)
    assert hdr in (['t', 'id', 'x', 'y'], ['t', 'id', 'x', 'y', 'pressure']), hdr
    for line in rd:
        t, i, x, y = line[:4]
        tf, xf, yf = float(t), float(x), float(y)
        for v, nm in ((tf, 't'), (xf, 'x'), (yf, 'y')):
            if not math.isfinite(v):
                bad.append((t, i, nm, v))
        rows[tf][int(i)] = (xf, yf, 1)
        ids.add(int(i))
times = sorted(rows)
# A frame with nobody in it has no rows, so a run that ends with everybody gone between two
# sampled frames ends on a frame the file cannot show: its time is the summary's t_final, and
# people.csv must say that everybody left by then.
summary_path = os.path.join(out, 'summary.json')
if times and os.path.exists(summary_path):
    try:
        t_end_run = json.load(open(summary_path)).get('t_final')
    except ValueError:
        t_end_run = None
    if (isinstance(t_end_run, (int, float)) and t_end_run > times[-1] + 1e-9 * max(1.0, abs(t_end_run))
            and N > 0 and all(d is not None and d[0] <= t_end_run + 1e-9 * max(1.0, abs(t_end_run))
                              for d in departures)):
        print(f'frame t={t_end_run}: empty (everybody left by then, as people.csv says), not written')
        rows[t_end_run] = {}
        times.append(t_end_run)
print(f'frames {len(times)}, t {times[0] if times else None}..{times[-1] if times else None}, ids {len(ids)}, scene people {N}')
if bad:
    print(f'NON-FINITE values: {len(bad)}, first {bad[:3]}')
if ids and (min(ids) < 0 or max(ids) > N - 1):
    print(f'ID MISMATCH: ids {sorted(ids)[:5]}..{max(ids)} vs N={N}'); flags.append('IDS')
# Who is missing from a frame has left by then, as people.csv says, or has not arrived yet (not
# written before); who is written has not left, and is due by then.
first_seen = {}
for t in times:
    for i in rows[t]:
        first_seen.setdefault(i, t)
for i, t in first_seen.items():
    if i < N and t < due[i] - 1e-9 * max(1.0, abs(due[i])):
        print(f'person {i} is written at t={t}, before their arrival is due at t={due[i]}')
        flags.append('EARLY_ARRIVAL'); break
for t in times:
    for i in range(N):
        d = departures[i]
        gone = d is not None and d[0] <= t + 1e-9 * max(1.0, abs(t))
        pending = not gone and first_seen.get(i, math.inf) > t
        if not pending and (i in rows[t]) == gone:
            print(f'frame t={t}: person {i} is {"written" if gone else "missing"}, people.csv says '
                  f'{"they left at t=" + str(d[0]) if gone else "they had not left"}')
            flags.append('DEPARTURES'); break
    else:
        continue
    break

# ---------- checks
worst_ov = (0.0, None)
worst_wall = (0.0, None)
worst_obs = (0.0, None)
outside_present = (0.0, None)
relapse = []
left_ever = set()
prev = None
worst_disp = (0.0, None)
first_empty = None
maxr = max(radii) if radii else 0
for t in times:
    fr = rows[t]
    pres = [(i, x, y) for i, (x, y, p) in fr.items()]
    for i in fr:
        if i in left_ever:
            relapse.append((t, i))
    if prev is not None:
        left_ever.update(i for i in prev[1] if i not in fr)
    # pairs via grid
    cell = 2 * maxr if maxr > 0 else 1.0
    grid = defaultdict(list)
    for (i, x, y) in pres:
        if not (math.isfinite(x) and math.isfinite(y)):
            continue
        grid[(math.floor(x / cell), math.floor(y / cell))].append((i, x, y))
    for (gx, gy), lst in grid.items():
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                other = grid.get((gx + dx, gy + dy))
                if not other:
                    continue
                for (i, x, y) in lst:
                    for (j, u, v) in other:
                        if j <= i:
                            continue
                        ov = radii[i] + radii[j] - math.hypot(x - u, y - v)
                        if ov > worst_ov[0]:
                            worst_ov = (ov, f'people {i},{j} at t={t}')
    for (i, x, y) in pres:
        if not (math.isfinite(x) and math.isfinite(y)):
            continue
        r = radii[i]
        for (a, b) in walls:
            pen = r - seg_dist((x, y), a, b)
            if pen > worst_wall[0]:
                worst_wall = (pen, f'person {i} wall {a}-{b} at t={t} centre ({x},{y})')
        for k, ob in enumerate(obstacles):
            pen = -obstacle_gap((x, y), r, ob, t)
            if pen > worst_obs[0]:
                worst_obs = (pen, f'person {i} obstacle #{k} at t={t}')
        if arena is not None:
            c, big = arena['center'], arena['radius']
            pen = math.hypot(x - c[0], y - c[1]) + r - big
            if pen > worst_wall[0]:
                worst_wall = (pen, f'person {i} arena wall at t={t} centre ({x},{y})')
        # a person written is present: their disk is not wholly outside the room
        if not inside_poly((x, y), poly) and dist_to_boundary((x, y), poly) >= r:
            outside_present = max(outside_present, (dist_to_boundary((x, y), poly), f'person {i} written wholly outside the room at t={t} ({x},{y})'), key=lambda z: z[0])
        # a present person's centre must be in the room or beyond an exit
        if not inside_poly((x, y), poly):
            d = dist_to_boundary((x, y), poly)
            near_exit = min([seg_dist((x, y), e0, e1) for e0, e1 in exits] or [1e300])
            if near_exit > d + 1e-9 and d > 1e-9:
                outside_present = max(outside_present, (d, f'present person {i} outside room not through exit at t={t} ({x},{y})'), key=lambda z: z[0])
    if prev is not None:
        pt, pf = prev
        dt = t - pt
        # An obstacle whose path turns between two frames is checked at each waypoint in
        # between too: a person who went straight from one frame to the other, at any pace,
        # overlaps a convex obstacle there whenever both ends do.
        for k, ob in enumerate(obstacles):
            mot = ob[2]
            if mot is None or mot[0] != 'path':
                continue
            for w in mot[1]:
                tw = w[0]
                if not pt < tw < t:
                    continue
                for i, (x, y, p) in fr.items():
                    if p != 1 or i not in pf or pf[i][2] != 1:
                        continue
                    pen = min(-obstacle_gap((x, y), radii[i], ob, tw),
                              -obstacle_gap(pf[i][:2], radii[i], ob, tw))
                    if pen > worst_obs[0]:
                        worst_obs = (pen, f'person {i} obstacle #{k} at its waypoint t={tw}, '
                                          f'between the frames {pt} and {t}')
        for i, (x, y, p) in fr.items():
            if i in pf:
                d = math.hypot(x - pf[i][0], y - pf[i][1])
                rate = d / dt if dt > 0 else float('inf')
                if rate > worst_disp[0]:
                    worst_disp = (rate, f'person {i} moved {d:.6g} in dt={dt:.6g} ({pt}->{t}), speed {speeds[i]}')
    everybody_left = all(d is not None and d[0] <= t + 1e-9 * max(1.0, abs(t)) for d in departures)
    if first_empty is None and N > 0 and not pres and everybody_left:
        first_empty = t
    prev = (t, fr)

print(f'max overlap        {worst_ov[0]:.3e}  {worst_ov[1]}')
print(f'max wall pen.      {worst_wall[0]:.3e}  {worst_wall[1]}')
print(f'max obstacle pen.  {worst_obs[0]:.3e}  {worst_obs[1]}')
print(f'outside/left issue {outside_present[0]:.3e}  {outside_present[1]}')
print(f'max speed seen     {worst_disp[0]:.6g}  {worst_disp[1]}  (max desired speed {max(speeds) if speeds else None})')
if relapse:
    print(f'RELAPSE (written again after leaving): {relapse[:5]}')
if worst_ov[0] > TOL: flags.append('OVERLAP')
if worst_wall[0] > TOL: flags.append('WALL')
if worst_obs[0] > TOL: flags.append('OBSTACLE')
if outside_present[0] > 1e-9: flags.append('OUTSIDE')
if bad: flags.append('NONFINITE')
if relapse: flags.append('RELAPSE')

# ---------- summary
sp = os.path.join(out, 'summary.json')
if os.path.exists(sp):
    raw = open(sp).read()
    if re.search(r'\bNaN\b|\bInfinity\b|\binf\b', raw):
        print('summary.json contains NaN/Infinity tokens'); flags.append('SUMMARY_NONFINITE')
    s = json.loads(raw)
    last = rows[times[-1]] if times else {}
    remaining = len(last)
    print(f"summary: status {s.get('status')} people {s.get('people')} remaining {s.get('people_remaining')} "
          f"evac {s.get('evacuation_time')} t_final {s.get('t_final')} max_overlap {s.get('max_overlap')} "
          f"max_wall_pen {s.get('max_wall_penetration')} error {str(s.get('error'))[:300]}")
    print(f'checker: remaining at last frame {remaining}, first empty frame t={first_empty}, last frame t={times[-1] if times else None}')
    if s.get('people') != N: flags.append(f"SUMMARY_PEOPLE({s.get('people')} vs {N})")
    if s.get('people_remaining') != remaining: flags.append(f"SUMMARY_REMAINING({s.get('people_remaining')} vs {remaining})")
    if times and s.get('t_final') is not None and abs(s['t_final'] - times[-1]) > 1e-9: flags.append(f"T_FINAL({s['t_final']} vs {times[-1]})")
    ev = s.get('evacuation_time')
    if first_empty is not None and ev is None and s.get('status') == 'completed':
        flags.append('EVAC_NULL_BUT_EMPTY')
    if ev is not None and first_empty is not None and ev > first_empty + 1e-9:
        flags.append(f'EVAC_LATE({ev} > {first_empty})')
    if ev is not None and first_empty is None:
        flags.append(f'EVAC_BUT_NOT_EMPTY')
    mo = s.get('max_overlap')
    if isinstance(mo, (int, float)) and worst_ov[0] > max(mo, 0) + 1e-12:
        flags.append(f'SUMMARY_OVERLAP_UNDER({mo} < {worst_ov[0]})')
    mw = s.get('max_wall_penetration')
    if isinstance(mw, (int, float)) and worst_wall[0] > max(mw, 0) + 1e-12:
        flags.append(f'SUMMARY_WALL_UNDER({mw} < {worst_wall[0]})')
    po = s.get('people_out')
    if po:
        # compare count out at each frame time with people_out staircase
        def out_at(t):
            c = 0
            for tt, k in po:
                if tt <= t + 1e-12:
                    c = k
            return c
        for t in times:
            # Out: written before and missing now (not the people still to arrive).
            k = sum(1 for i in first_seen if first_seen[i] <= t and i not in rows[t]) + sum(
                1 for i, d in enumerate(departures)
                if i not in first_seen and d is not None and d[0] <= t + 1e-9 * max(1.0, abs(t)))
            if k != out_at(t):
                flags.append(f'PEOPLE_OUT_MISMATCH(t={t}: csv {k} vs summary {out_at(t)})'); break
else:
    print('no summary.json'); flags.append('NO_SUMMARY')
print('FLAGS:', flags if flags else 'none')
sys.exit(1 if flags else 0)
