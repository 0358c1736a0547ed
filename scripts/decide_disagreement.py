#!/usr/bin/env python3
"""Decides a cross-check's stop, or its closest call: which of the two answers in a
`disagreement.json` (or a `largest-gap.json`) is the projection. Written apart from the Rust
code; run it through `scripts/decide-disagreement`, which provides NumPy and SciPy.

usage: scripts/decide-disagreement OUTDIR/disagreement.json [--coordinate J] [--tol 1e-9]
       scripts/decide-disagreement OUTDIR/largest-gap.json [--coordinate J] [--tol 1e-9]

`sweep run --backend cross…` writes `disagreement.json` when its two backends disagree beyond
the tolerance, and `largest-gap.json` for the largest gap that passed: the step's problem
`min ½‖x − y‖² s.t. A x ≥ b` and both answers. A projection is unique, so the step is decided
by computing it independently and certifying it:

1. The block of the coordinate where the answers differ most (or `--coordinate J`): the
   connected component of the rows sharing an unknown with it, which the projection
   separates from the rest.
2. Candidate supports: first each answer's own (its rows with positive multipliers: seconds
   to try), then, when none of them certifies, the least-distance program's, `min ‖z‖ s.t.
   A z ≥ b − A y` solved as Lawson and Hanson's non-negative least-squares problem (SciPy's
   `nnls`, dense: minutes for a few thousand rows). Where a support comes from does not
   matter: the certificate is checked on the data alone. A support whose projection violates
   rows by more than rounding allows is tried again with them (up to three times): a support
   can miss rows that depend on it and are tight at the projection.
3. For each, the projection onto the support's affine set (Cholesky of `A_S A_Sᵀ` on a
   linearly independent subset of the support, chosen by QR with column pivoting), refined
   with residuals in extended precision (`numpy.longdouble`).
4. Its certificate, the KKT conditions: `x − y = A_Sᵀ λ` with `λ ≥ 0` (found by
   non-negative least squares over the whole support, dependent rows making multipliers
   non-unique), the support's equations solved, every row of the block satisfied. A point
   that passes them is the projection (up to the printed residuals), whatever found its
   support; the first support that certifies decides.

Prints each answer's distance from the certified projection (∞-norm) and which answers are
within `--tol` of it. Exits with 1 when no support certifies, 0 otherwise.
"""
import argparse
import json
import sys
import time

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
from scipy.optimize import nnls


def block_of(problem, coordinate):
    """Rows and unknowns of the connected component (rows sharing an unknown) holding
    `coordinate`; stored zeros connect nothing."""
    a = problem["a"]
    n, rp, ci, va = a["n_cols"], a["row_ptr"], a["col_idx"], a["values"]
    parent = list(range(n))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    m = len(rp) - 1
    for i in range(m):
        cols = [ci[k] for k in range(rp[i], rp[i + 1]) if va[k] != 0.0]
        for c in cols[1:]:
            ra, rb = root(cols[0]), root(c)
            if ra != rb:
                parent[ra] = rb
    r0 = root(coordinate)
    rows = [
        i
        for i in range(m)
        if any(va[k] != 0.0 and root(ci[k]) == r0 for k in range(rp[i], rp[i + 1]))
    ]
    cols = sorted({ci[k] for i in rows for k in range(rp[i], rp[i + 1]) if va[k] != 0.0})
    return rows, cols


def certify(A, y, b, support, label):
    """Projects y onto the affine set of `support` (an independent subset of its rows, chosen
    by QR with column pivoting; residuals in extended precision) and checks the KKT
    conditions: non-negative multipliers on the support (found by non-negative least squares
    over every row of it, since dependent rows make them non-unique), its rows tight, every
    row satisfied. Returns the point and whether it passed."""
    _, R, piv = sl.qr(A[support].T, mode="economic", pivoting=True)
    diag = np.abs(np.diag(R))
    rank = int((diag > diag[0] * 1e-10).sum())
    independent = np.sort(support[piv[:rank]])
    Al = A.astype(np.longdouble)
    rl = b.astype(np.longdouble) - Al @ y.astype(np.longdouble)
    cho = sl.cho_factor(A[independent] @ A[independent].T)
    mu = np.zeros(rank, dtype=np.longdouble)
    for _ in range(8):
        residual = rl[independent] - Al[independent] @ (Al[independent].T @ mu)
        mu += sl.cho_solve(cho, residual.astype(np.float64)).astype(np.longdouble)
    d = Al[independent].T @ mu
    slack = Al @ d - rl
    x = y.astype(np.longdouble) + d
    violation = float(max(0.0, -slack.min()))
    unsolved = float(np.abs(slack[support]).max())
    # Stationarity with multipliers >= 0 over the whole support: d = A_Sᵀ λ, λ >= 0.
    lam, _ = nnls(A[support].T, d.astype(np.float64), maxiter=50 * len(support))
    stationarity = float(np.abs(A[support].T @ lam - d.astype(np.float64)).max())
    scale = max(1.0, float(np.abs(d).max()))
    positive = lam > 0
    smallest = float(lam[positive].min()) if positive.any() else 0.0
    print(
        f"{label} support, {len(support)} rows: rank {rank} "
        f"(smallest |R_ii|/|R_00| kept {diag[rank - 1] / diag[0]:.2e}); multipliers >= 0 "
        f"leave x - y unexplained by {stationarity:.2e} ({int(positive.sum())} positive, "
        f"smallest {smallest:.2e}); support equations to {unsolved:.2e}; every row of the "
        f"block to {violation:.2e}"
    )
    ok = stationarity <= 1e-12 * scale and unsolved <= 1e-14 and violation <= 1e-14
    print(f"  certified: {'yes' if ok else 'NO'}")
    return x, ok


def least_distance_support(A, y, b):
    """The support of the least-distance program `min ‖z‖ s.t. A z ≥ b − A y`, solved as
    Lawson and Hanson's non-negative least-squares problem: u ≥ 0 minimizing ‖E u − e‖ with
    E = [Aᵀ; (b − A y)ᵀ]. `None` when it says the block is infeasible."""
    r = b - A @ y
    E = np.vstack([A.T, r[None, :]])
    e = np.zeros(A.shape[1] + 1)
    e[-1] = 1.0
    started = time.time()
    u, _ = nnls(E, e, maxiter=50 * A.shape[0])
    if not (E @ u - e)[-1] < 0:
        return None
    support = np.where(u > 0)[0]
    print(f"least-distance program: {time.time() - started:.1f} s, support of {len(support)} rows")
    return support


def certify_with_joins(A, y, b, support, label):
    """`certify`, and when the support's projection violates rows of the block by more than
    rounding allows, again with them joined, up to three times: a support may miss rows that
    depend on it and are tight at the projection (1.25e-14 at a door queue of the hall, where
    the least-distance program's support missed such rows)."""
    x, ok = certify(A, y, b, support, label)
    for _ in range(3):
        if ok:
            break
        slack = A.astype(np.longdouble) @ x - b.astype(np.longdouble)
        violated = np.setdiff1d(np.where(slack < -1e-14)[0], support)
        if not len(violated):
            break
        support = np.union1d(support, violated)
        x, ok = certify(A, y, b, support, f"{label} (+{len(violated)} rows it violated)")
    return x, ok


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file")
    ap.add_argument("--coordinate", type=int, default=None)
    ap.add_argument("--tol", type=float, default=1e-9)
    args = ap.parse_args()

    data = json.load(open(args.file))
    problem = data["problem"]
    names = (data["first_backend"], data["second_backend"])
    answers = (np.array(data["first"]["x"]), np.array(data["second"]["x"]))
    coordinate = data["coordinate"] if args.coordinate is None else args.coordinate
    a = problem["a"]
    m_all, n_all = len(a["row_ptr"]) - 1, a["n_cols"]
    print(
        f"{args.file}: {m_all} rows on {n_all} unknowns; {names[0]} and {names[1]} differ by "
        f"{data['gap']:.3e} (coordinate {data['coordinate']})"
    )
    if np.finfo(np.longdouble).eps > 1e-18:
        print("note: numpy.longdouble is double precision here; the refinement gains nothing")

    rows, cols = block_of(problem, coordinate)
    if not rows:
        print(f"coordinate {coordinate} is touched by no row: both answers must be y there")
        return 0
    local = {c: j for j, c in enumerate(cols)}
    rp, ci, va = a["row_ptr"], a["col_idx"], a["values"]
    A = np.zeros((len(rows), len(cols)))
    for t, i in enumerate(rows):
        for k in range(rp[i], rp[i + 1]):
            if va[k] != 0.0:
                A[t, local[ci[k]]] += va[k]
    y = np.array([problem["y"][c] for c in cols])
    b = np.array([problem["b"][i] for i in rows])
    print(f"block of coordinate {coordinate}: {len(rows)} rows on {len(cols)} unknowns")

    # 2. The answers' own supports (rows with positive multipliers) first: trying one takes
    # seconds, where the least-distance program takes minutes on a few thousand rows.
    candidates = []
    for name, side in zip(names, ("first", "second")):
        multipliers = data[side].get("multipliers") or []
        if len(multipliers) == m_all:
            support = np.array([t for t, i in enumerate(rows) if multipliers[i] > 0.0], dtype=int)
            if len(support):
                candidates.append((f"{name}'s", lambda support=support: support))
    candidates.append(("the least-distance program's", lambda: least_distance_support(A, y, b)))

    x, ok = None, False
    for label, find in candidates:
        support = find()
        if support is None:
            print("the least-distance program says the block is infeasible")
            return 1
        x, ok = certify_with_joins(A, y, b, support, label)
        if ok:
            break
    if not ok:
        print("no support certifies: the distances below (from the last one tried) are not decided")
    for name, answer in zip(names, answers):
        off = float(np.abs(answer[cols] - x).max())
        verdict = "within" if off <= args.tol else "NOT within"
        print(f"  {name}: {off:.3e} from the projection ({verdict} {args.tol:g})")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
