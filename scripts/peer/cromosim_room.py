"""A square room with one door run by cromosim (Python, cvxopt), the peer implementation of the same
prediction-projection scheme, from given initial positions, every phase of its loop timed.

cromosim draws walls as pixels of an image whose origin must be (0, 0): the room of side L
(`--room`, the paper's 10 m by default) is the interior [1, L + 1]^2 of an image 2 m wider, so
its coordinates are ours plus 1. Its door is the middle `--door` metres (1.2 by default) of the
right wall, and people are removed when they reach a line 0.9 m past it.

    python cromosim_room.py --init xyrv.npy --dt 0.01 --outdir DIR [--room 37 --door 2 --tf 15]

prints one line of JSON: steps, final time, ms per step in all and by phase.
"""
import argparse
import contextlib
import io
import json
import os
import time

import numpy as np
import matplotlib

matplotlib.use("Agg")
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from cromosim.domain import Domain, Destination  # noqa: E402
from cromosim.micro import (  # noqa: E402
    compute_contacts,
    move_people,
    people_update_destination,
    projection,
)

ap = argparse.ArgumentParser()
ap.add_argument("--init", required=True, help=".npy array of rows x, y, r, v (cromosim coordinates)")
ap.add_argument("--dt", type=float, default=0.01)
ap.add_argument("--tf", type=float, default=40.0)
ap.add_argument("--outdir", required=True)
ap.add_argument("--room", type=float, default=10.0, help="side of the square room, m")
ap.add_argument("--door", type=float, default=1.2, help="width of the door, m")
args = ap.parse_args()
os.makedirs(args.outdir, exist_ok=True)
os.chdir(args.outdir)  # cromosim writes its domain image into the working directory

ROOM, MARGIN, DOOR, PIXEL = args.room, 1.0, args.door, 0.05
side = ROOM + 2 * MARGIN
pixels = int(round(side / PIXEL))
black, red = [0, 0, 0], [255, 0, 0]
dom = Domain(name="room", pixel_size=PIXEL, xmin=0.0, ymin=0.0, width=pixels, height=pixels,
             wall_colors=[black])
lo, hi = MARGIN + (ROOM - DOOR) / 2, MARGIN + (ROOM + DOOR) / 2
right = MARGIN + ROOM
for x0, y0, w, h in [(0, 0, MARGIN, side), (0, 0, side, MARGIN), (0, right, side, MARGIN),
                     (right, 0, MARGIN, lo), (right, hi, MARGIN, side - hi)]:
    dom.add_shape(Rectangle((x0, y0), w, h), outline_color=black, fill_color=black)
dom.add_shape(Line2D([right + 0.9, right + 0.9], [lo, hi], linewidth=2),
              outline_color=red, fill_color=red)
dom.build_domain()
dom.add_destination(Destination(name="door", colors=[red], excluded_colors=[black]))

xyrv = np.load(args.init)
n = xyrv.shape[0]
# The same dictionary cromosim's own people_initialization returns.
people = {"xyrv": xyrv, "Vd": np.zeros((n, 2)), "U": np.zeros((n, 2)), "Uold": np.zeros((n, 2)),
          "destinations": np.array(["door"] * n, dtype="U20"), "paths": {},
          "rng": np.random.default_rng(0),
          "id": np.char.add(["room_"] * n, np.arange(n).astype("<U6")),
          "last_id": f"room_{n - 1}"}
# Contacts within the distance a person can close in one step at speed 1 (cromosim's choice).
dmax = 2.0 * float(xyrv[:, 3].max()) * args.dt
phases = {"desired velocity": 0.0, "contacts": 0.0, "projection": 0.0, "move": 0.0,
          "removal at the door": 0.0}
everybody = {"room": people}
t, steps = 0.0, 0
while t < args.tf and everybody["room"]["xyrv"].shape[0] > 0:
    p = everybody["room"]
    a = time.perf_counter()
    _, _, p["Vd"] = dom.people_desired_velocity(p["xyrv"], p["destinations"])
    b = time.perf_counter()
    contacts = compute_contacts(dom, p["xyrv"], dmax)
    c = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        _, _, p["U"], _, _ = projection(args.dt, p["xyrv"], contacts, p["Vd"],
                                        dmin_people=0.0, dmin_walls=0.0, method="cvxopt",
                                        log=False)
    d = time.perf_counter()
    p, _ = move_people(t, args.dt, p, [])
    everybody["room"] = p
    e = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        everybody = people_update_destination(everybody, {"room": dom}, dom.pixel_size)
    f = time.perf_counter()
    for name, dt in zip(phases, [b - a, c - b, d - c, e - d, f - e]):
        phases[name] += dt
    t += args.dt
    steps += 1

total = sum(phases.values())
print(json.dumps({"steps": steps, "t_final": round(t, 6),
                  "remaining": int(everybody["room"]["xyrv"].shape[0]),
                  "ms_per_step": 1e3 * total / max(steps, 1),
                  "ms_per_step_by_phase": {k: 1e3 * v / max(steps, 1) for k, v in phases.items()}}))
