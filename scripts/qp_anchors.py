#!/usr/bin/env python3
"""Anchors: existing QP solvers (from PyPI) on the recorded projection QPs.

What it measures
----------------
Each recorded QP is the projection  x* = argmin ½‖x − y‖²  s.t.  A x ≥ b,  stored as the
JSON of `sweeping_api::ProjectionProblem` ({"y", "a", "b", "keys"?}, `a` being `SparseRows`:
CSR with "n_cols", "row_ptr", "col_idx", "values"), either at the top level or under the key
"problem". Every solver is given the displacement form

    d = x − y:   min ½‖d‖²  s.t.  A d ≥ r,   r = b − A y,

which is much better conditioned (coordinates are ~10–40 m, displacements ~1e-2).

For each (problem, solver) it reports:

* cold: median wall time of up to 5 solves (fewer when one solve is slow, see
  REPEAT_BUDGET), timing only the solver's own set-up (creating its objects, passing the
  data, its factorizations) and the solve call; the JSON loading and the conversion of A
  to the solver's format (CSC, dense, cvxopt or HiGHS structures) are done once, untimed;
* accuracy against a reference answer (x_ref, λ_ref) computed beforehand by the project's
  own exact solver: ‖x − x_ref‖∞, ‖λ − λ_ref‖∞ (λ ≥ 0 with x − y = Aᵀλ, mapped from each
  solver's sign convention), the largest violation max(0, max(b − A x)), iterations and the
  solver's status;
* warm: the problem of a next time step, y' = y + δ with δ uniform in [−1e-3, 1e-3] per
  coordinate (seeded, PERTURB_SEED), same A and b. It is solved cold (the reference time)
  and, for the solvers with a documented warm start, from the unperturbed problem's exact
  answer (d0 = x_ref − y', λ0 = λ_ref, the same start for every solver), with a fresh
  set-up each time (in the simulation A changes from step to step, so no factorization can
  be kept). Accuracy there is against the perturbed problem's reference answer.

The problems are run from the smallest (rows, then unknowns) up. A solve whose first run
takes longer than FIRST_SOLVE_LIMIT seconds is stopped and reported as a time-out (so is
one stopped by the solver's own time limit), and that solver is then skipped on the
problems at least as large in rows and unknowns. The perturbed and warm solves are
measured only when the cold solve took less than WARM_LIMIT seconds. Every
(problem, solver) runs in a child process, so a crash or a hang in one solver does not
end the run.

How to run it
-------------
1. Write the perturbed problems (PROBLEM_perturbed.json) into the reference folder:

       python3 scripts/qp_anchors.py perturb REFS_DIR QP.json...

2. Compute the references (STEM_ref.json and STEM_perturbed_ref.json, each
   {"x", "multipliers", "backend", ...}, STEM being the input file's name without ".json")
   with the project's own example program:

       cargo run --release --example project_qp -- --backend clarabel REFS_DIR QP.json...
       cargo run --release --example project_qp -- --backend clarabel REFS_DIR REFS_DIR/*_perturbed.json

   (Clarabel's answers, polished by the active set down to tests at 1e-15, are the exact
   ones; `--backend native` gives the default backend's, to its accuracy contract.)

3. Measure, pinned to one core:

       taskset -c 0 python3 scripts/qp_anchors.py run --refs REFS_DIR --out results.csv QP.json...

   Options: --solvers piqp,osqp,... (default: all), --repeats N (default 5).

Packages
--------
numpy, scipy, and the solvers: piqp, clarabel, osqp, proxsuite, qpalm, daqp, quadprog,
cvxopt, highspy (`pip install numpy scipy piqp clarabel osqp proxsuite qpalm daqp quadprog
cvxopt highspy`). A solver whose package is missing is reported as such and skipped.
Tested with piqp 0.7.0, clarabel 0.11.1, osqp 1.1.3, proxsuite 0.8.0, qpalm 1.3.0,
daqp 0.11.0, quadprog 0.1.14, cvxopt 1.3.3, highspy 1.16.0.

Settings (all solvers single-threaded, silent)
----------------------------------------------
See SOLVERS below; each class's `settings` dict is written to the CSV's `settings` column.
"""

import os

# Single-threaded BLAS/OpenMP for every solver (set before numpy and the solvers load).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import csv
import importlib
import json
import math
import multiprocessing
import statistics
import sys
import time
import traceback
from pathlib import Path

import numpy as np
import scipy.sparse as sp

PERTURB_SEED = 20240601
PERTURB_SIZE = 1e-3
TOLERANCE = 1e-9
# A first solve longer than this (seconds) is stopped: "timeout".
FIRST_SOLVE_LIMIT = 60.0
# Repeats of one measurement are cut so that they take about this long in all (seconds).
REPEAT_BUDGET = 10.0
# The perturbed and warm solves are measured only when a cold solve took less (seconds).
WARM_LIMIT = 20.0
# Wall-clock cap on one (problem, solver) child process (seconds).
CHILD_LIMIT = 900.0
# Stand-in for +∞ where a solver's documentation asks for a large finite bound.
BIG = 1e20


# --------------------------------------------------------------------------------------
# Problems


class Problem:
    """One recorded QP in displacement form, with the formats the solvers take."""

    def __init__(self, path):
        self.path = Path(path)
        self.name = self.path.stem
        data = json.loads(self.path.read_text())
        if "problem" in data:
            data = data["problem"]
        a = data["a"]
        n_rows = len(a["row_ptr"]) - 1
        self.y = np.array(data["y"], dtype=float)
        self.b = np.array(data["b"], dtype=float)
        self.a_csr = sp.csr_matrix(
            (np.array(a["values"], dtype=float),
             np.array(a["col_idx"], dtype=np.int64),
             np.array(a["row_ptr"], dtype=np.int64)),
            shape=(n_rows, a["n_cols"]),
        )
        self.a_csc = self.a_csr.tocsc()
        self.a_csc.sort_indices()
        self.n = self.a_csr.shape[1]
        self.m = n_rows
        self._dense = None

    def rhs(self, y):
        """r = b − A y for the displacement form at y."""
        return self.b - self.a_csr @ y

    def dense(self):
        """A as a dense C-ordered array (for the dense solvers), made once."""
        if self._dense is None:
            self._dense = self.a_csr.toarray()
        return self._dense

    def max_violation(self, x):
        return max(0.0, float(np.max(self.b - self.a_csr @ x))) if self.m else 0.0

    def perturbed_y(self):
        rng = np.random.default_rng(PERTURB_SEED)
        return self.y + rng.uniform(-PERTURB_SIZE, PERTURB_SIZE, size=self.n)


def write_perturbed(paths, out_dir):
    """Writes STEM_perturbed.json (the problem with y' = y + δ) for each QP file."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for path in paths:
        problem = Problem(path)
        data = json.loads(Path(path).read_text())
        if "problem" in data:
            data = data["problem"]
        data["y"] = problem.perturbed_y().tolist()
        target = out_dir / f"{problem.name}_perturbed.json"
        target.write_text(json.dumps(data))
        print(f"wrote {target}")


def load_reference(refs_dir, stem):
    path = Path(refs_dir) / f"{stem}_ref.json"
    if not path.exists():
        return None
    data = json.loads(path.read_text())
    return {
        "x": np.array(data["x"], dtype=float),
        "multipliers": np.array(data["multipliers"], dtype=float),
        "backend": data.get("backend", "?"),
    }


# --------------------------------------------------------------------------------------
# Solvers
#
# Each solver class has:
#   prepare(problem, r) -> data     untimed: conversion of A, r to the solver's format
#   start(data, d0, lam0) -> start  untimed: the warm start in the solver's format
#   solve(data, start) -> Outcome   timed inside: set-up and solve only
# `lam` in an Outcome follows the projection's convention: λ ≥ 0 with d = Aᵀλ.


class Outcome:
    def __init__(self, seconds, d, lam, iterations, status, solved):
        self.seconds = seconds
        self.d = None if d is None else np.asarray(d, dtype=float).ravel()
        self.lam = None if lam is None else np.asarray(lam, dtype=float).ravel()
        self.iterations = iterations
        self.status = status
        self.solved = solved


class Piqp:
    name = "piqp"
    module = "piqp"
    imports = ["piqp"]
    warm_reason = "no warm-start argument in the Python API (solve() takes none)"
    settings = {"eps_abs": TOLERANCE, "eps_rel": TOLERANCE,
                "eps_duality_gap_abs": TOLERANCE, "eps_duality_gap_rel": TOLERANCE,
                "max_iter": 500, "num_threads": 1, "verbose": False}

    def prepare(self, problem, r):
        return {"P": sp.identity(problem.n, format="csc"), "c": np.zeros(problem.n),
                "G": problem.a_csc, "h_l": r}

    def solve(self, data, start=None):
        import piqp
        t0 = time.perf_counter()
        solver = piqp.SparseSolver()
        for key, value in self.settings.items():
            setattr(solver.settings, key, value)
        # h_l ≤ G d (h_u omitted: +∞).
        solver.setup(data["P"], data["c"], None, None, data["G"], data["h_l"], None)
        status = solver.solve()
        seconds = time.perf_counter() - t0
        result = solver.result
        return Outcome(seconds, result.x, result.z_l, result.info.iter, str(status),
                       status == piqp.PIQP_SOLVED)


class Clarabel:
    name = "clarabel"
    module = "clarabel"
    imports = ["clarabel"]
    warm_reason = "no warm start in the Python API of clarabel 0.11 (DefaultSolver(P, q, A, b, cones, settings).solve())"
    settings = {"tol_gap_abs": TOLERANCE, "tol_gap_rel": TOLERANCE, "tol_feas": TOLERANCE,
                "max_iter": 500, "max_threads": 1, "verbose": False}

    def prepare(self, problem, r):
        import clarabel
        settings = clarabel.DefaultSettings()
        for key, value in self.settings.items():
            setattr(settings, key, value)
        # −A d + s = −r, s ≥ 0.
        return {"P": sp.identity(problem.n, format="csc"), "q": np.zeros(problem.n),
                "A": (-problem.a_csc).tocsc(), "b": -r,
                "cones": [clarabel.NonnegativeConeT(problem.m)], "settings": settings}

    def solve(self, data, start=None):
        import clarabel
        t0 = time.perf_counter()
        solver = clarabel.DefaultSolver(data["P"], data["q"], data["A"], data["b"],
                                        data["cones"], data["settings"])
        solution = solver.solve()
        seconds = time.perf_counter() - t0
        return Outcome(seconds, solution.x, solution.z, solution.iterations,
                       str(solution.status), solution.status == clarabel.SolverStatus.Solved)


class Osqp:
    name = "osqp"
    module = "osqp"
    imports = ["osqp"]
    warm_reason = None
    settings = {"eps_abs": TOLERANCE, "eps_rel": TOLERANCE, "polishing": True,
                "max_iter": 100000, "verbose": False}

    def prepare(self, problem, r):
        return {"P": sp.identity(problem.n, format="csc"), "q": np.zeros(problem.n),
                "A": problem.a_csc, "l": r, "u": np.full(problem.m, np.inf)}

    def start(self, data, d0, lam0):
        # OSQP's y is negative on an active lower bound: y = −λ.
        return {"x": d0, "y": -lam0}

    def solve(self, data, start=None):
        import osqp
        t0 = time.perf_counter()
        solver = osqp.OSQP()
        solver.setup(data["P"], data["q"], data["A"], data["l"], data["u"], **self.settings)
        if start is not None:
            solver.warm_start(x=start["x"], y=start["y"])
        result = solver.solve(raise_error=False)
        seconds = time.perf_counter() - t0
        info = result.info
        status = f"{info.status} (polish {info.status_polish})"
        return Outcome(seconds, result.x, -result.y, info.iter, status,
                       info.status_val == 1)


class Proxsuite:
    name = "proxqp"
    module = "proxsuite"
    imports = ["proxsuite"]
    warm_reason = None
    settings = {"eps_abs": TOLERANCE, "eps_rel": TOLERANCE, "max_iter": 100000,
                "verbose": False}

    def prepare(self, problem, r):
        return {"n": problem.n, "m": problem.m,
                "H": sp.identity(problem.n, format="csc"), "g": np.zeros(problem.n),
                "C": problem.a_csc, "l": r, "u": np.full(problem.m, BIG)}

    def start(self, data, d0, lam0):
        # ProxQP's z is negative on an active lower bound: z = −λ.
        return {"x": d0, "z": -lam0}

    def solve(self, data, start=None):
        import proxsuite
        t0 = time.perf_counter()
        qp = proxsuite.proxqp.sparse.QP(data["n"], 0, data["m"])
        for key, value in self.settings.items():
            setattr(qp.settings, key, value)
        if start is not None:
            qp.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START
        qp.init(data["H"], data["g"], None, None, data["C"], data["l"], data["u"])
        if start is None:
            qp.solve()
        else:
            qp.solve(start["x"], None, start["z"])
        seconds = time.perf_counter() - t0
        info = qp.results.info
        return Outcome(seconds, qp.results.x, -qp.results.z, info.iter, str(info.status),
                       info.status == proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED)


class ProxsuiteDense(Proxsuite):
    """ProxQP's dense back end, told that H is diagonal (HessianType.Diagonal)."""
    name = "proxqp-dense"
    dense = True

    def prepare(self, problem, r):
        return {"n": problem.n, "m": problem.m, "H": np.identity(problem.n),
                "g": np.zeros(problem.n), "C": problem.dense(), "l": r,
                "u": np.full(problem.m, BIG)}

    def solve(self, data, start=None):
        import proxsuite
        dense = proxsuite.proxqp.dense
        t0 = time.perf_counter()
        qp = dense.QP(data["n"], 0, data["m"], False, dense.HessianType.Diagonal)
        for key, value in self.settings.items():
            setattr(qp.settings, key, value)
        if start is not None:
            qp.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START
        qp.init(data["H"], data["g"], None, None, data["C"], data["l"], data["u"])
        if start is None:
            qp.solve()
        else:
            qp.solve(start["x"], None, start["z"])
        seconds = time.perf_counter() - t0
        info = qp.results.info
        return Outcome(seconds, qp.results.x, -qp.results.z, info.iter, str(info.status),
                       info.status == proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED)


class Qpalm:
    name = "qpalm"
    module = "qpalm"
    imports = ["qpalm"]
    warm_reason = None
    # The infeasibility tests' tolerances (default 1e-5) are tightened below the
    # optimality tolerance: at their defaults QPALM stopped on a feasible problem
    # (large_evacuation_h005) with "primal infeasible".
    settings = {"eps_abs": TOLERANCE, "eps_rel": TOLERANCE, "eps_prim_inf": 1e-12,
                "eps_dual_inf": 1e-12, "max_iter": 100000, "verbose": 0}

    def prepare(self, problem, r):
        import qpalm
        settings = qpalm.Settings()
        for key, value in self.settings.items():
            setattr(settings, key, value)
        return {"n": problem.n, "m": problem.m, "Q": sp.identity(problem.n, format="csc"),
                "q": np.zeros(problem.n), "A": problem.a_csc, "bmin": r,
                "bmax": np.full(problem.m, BIG), "settings": settings}

    def start(self, data, d0, lam0):
        # QPALM's y is negative on an active lower bound: y = −λ.
        return {"x": d0, "y": -lam0}

    def solve(self, data, start=None):
        import qpalm
        t0 = time.perf_counter()
        qp = qpalm.Data(data["n"], data["m"])
        qp.Q = data["Q"]
        qp.q = data["q"]
        qp.A = data["A"]
        qp.bmin = data["bmin"]
        qp.bmax = data["bmax"]
        solver = qpalm.Solver(qp, data["settings"])
        if start is not None:
            solver.warm_start(start["x"], start["y"])
        solver.solve()
        seconds = time.perf_counter() - t0
        info = solver.info
        return Outcome(seconds, solver.solution.x, -np.asarray(solver.solution.y),
                       info.iter, info.status, info.status_val == qpalm.Info.SOLVED)


class Daqp:
    name = "daqp"
    module = "daqp"
    imports = ["daqp"]
    warm_reason = None
    dense = True
    settings = {"primal_tol": TOLERANCE, "iter_limit": 1000000, "eps_prox": 0.0}

    def prepare(self, problem, r):
        return {"H": np.identity(problem.n), "f": np.zeros(problem.n),
                "A": problem.dense(), "bupper": np.full(problem.m, 1e30), "blower": r,
                "sense": np.zeros(problem.m, dtype=np.int32)}

    def start(self, data, d0, lam0):
        # DAQP's λ is negative on an active lower bound.
        return {"primal_start": d0, "dual_start": -lam0}

    def solve(self, data, start=None):
        import daqp
        extra = {} if start is None else start
        t0 = time.perf_counter()
        x, _fval, exitflag, info = daqp.solve(data["H"], data["f"], data["A"],
                                              data["bupper"], data["blower"], data["sense"],
                                              **self.settings, **extra)
        seconds = time.perf_counter() - t0
        return Outcome(seconds, x, -np.asarray(info["lam"]), info["iterations"],
                       f"exitflag {exitflag}", exitflag == 1)


class Quadprog:
    name = "quadprog"
    module = "quadprog"
    imports = ["quadprog"]
    warm_reason = "no warm start (Goldfarb–Idnani from the unconstrained minimum)"
    dense = True
    # factorized=True: G is passed as R⁻¹ with G = RᵀR; for G = I that is I itself,
    # which spares quadprog an n³ Cholesky of the identity.
    settings = {"factorized": True}

    def prepare(self, problem, r):
        # quadprog: min ½ xᵀGx − aᵀx  s.t.  Cᵀx ≥ b, C of shape (n, m), Fortran order.
        return {"G": np.identity(problem.n), "a": np.zeros(problem.n),
                "C": problem.dense().T, "b": np.array(r)}

    def solve(self, data, start=None):
        import quadprog
        t0 = time.perf_counter()
        try:
            x, _f, _xu, iterations, lagrangian, _iact = quadprog.solve_qp(
                data["G"], data["a"], data["C"], data["b"], 0, self.settings["factorized"])
        except ValueError as error:
            seconds = time.perf_counter() - t0
            return Outcome(seconds, None, None, "", f"error: {error}", False)
        seconds = time.perf_counter() - t0
        return Outcome(seconds, x, lagrangian, int(iterations[0]), "solved", True)


class Cvxopt:
    name = "cvxopt"
    module = "cvxopt"
    imports = ["cvxopt", "cvxopt.solvers", "cvxopt.coneprog"]
    warm_reason = None
    settings = {"abstol": TOLERANCE, "reltol": TOLERANCE, "feastol": TOLERANCE,
                "maxiters": 200, "show_progress": False}

    def prepare(self, problem, r):
        from cvxopt import matrix, spmatrix
        coo = (-problem.a_csr).tocoo()
        n = problem.n
        return {
            "P": spmatrix(1.0, range(n), range(n)),
            "q": matrix(0.0, (n, 1)),
            # G d ≤ h with G = −A, h = −r.
            "G": spmatrix(coo.data.tolist(), coo.row.tolist(), coo.col.tolist(),
                          (problem.m, n)),
            "h": matrix(-r),
            "A": problem.a_csr,
            "r": r,
        }

    def start(self, data, d0, lam0):
        # Interior point: the slacks s = A d0 − r and multipliers z = λ0 must be > 0;
        # both are lifted to at least FLOOR.
        from cvxopt import matrix
        floor = 1e-8
        s = np.maximum(data["A"] @ d0 - data["r"], floor)
        z = np.maximum(lam0, floor)
        return {"x": matrix(d0), "s": matrix(s), "z": matrix(z)}

    def solve(self, data, start=None):
        from cvxopt import solvers
        t0 = time.perf_counter()
        solution = solvers.qp(data["P"], data["q"], data["G"], data["h"],
                              initvals=start, options=dict(self.settings))
        seconds = time.perf_counter() - t0
        d = None if solution["x"] is None else np.array(solution["x"]).ravel()
        lam = None if solution["z"] is None else np.array(solution["z"]).ravel()
        return Outcome(seconds, d, lam, solution["iterations"], solution["status"],
                       solution["status"] == "optimal")


class Highs:
    module = "highspy"
    imports = ["highspy"]
    # HiGHS can hot start its QP solver from a solution and basis set on the Highs object
    # (setSolution/setBasis); not tried, since qpasm did not solve these problems cold.
    warm_reason = "not measured: qpasm did not solve these problems cold"
    method = "qpasm"

    def __init__(self, method):
        self.method = method
        self.name = f"highs-{method}"
        self.settings = {"solver": method, "output_flag": False, "threads": 1,
                         "primal_feasibility_tolerance": TOLERANCE,
                         "dual_feasibility_tolerance": TOLERANCE,
                         "qp_nullspace_limit": 100000, "small_matrix_value": 1e-12,
                         "time_limit": FIRST_SOLVE_LIMIT - 5.0}
        if method == "hipo":
            self.settings["ipm_optimality_tolerance"] = TOLERANCE

    def prepare(self, problem, r):
        import highspy
        inf = highspy.kHighsInf
        lp = highspy.HighsLp()
        lp.num_col_ = problem.n
        lp.num_row_ = problem.m
        lp.col_cost_ = np.zeros(problem.n)
        lp.col_lower_ = np.full(problem.n, -inf)
        lp.col_upper_ = np.full(problem.n, inf)
        lp.row_lower_ = np.array(r)
        lp.row_upper_ = np.full(problem.m, inf)
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = problem.a_csc.indptr.astype(np.int32)
        lp.a_matrix_.index_ = problem.a_csc.indices.astype(np.int32)
        lp.a_matrix_.value_ = problem.a_csc.data
        lp.a_matrix_.num_col_ = problem.n
        lp.a_matrix_.num_row_ = problem.m
        hessian = highspy.HighsHessian()
        hessian.dim_ = problem.n
        hessian.format_ = highspy.HessianFormat.kTriangular
        hessian.start_ = np.arange(problem.n + 1, dtype=np.int32)
        hessian.index_ = np.arange(problem.n, dtype=np.int32)
        hessian.value_ = np.ones(problem.n)
        return {"lp": lp, "hessian": hessian}

    def solve(self, data, start=None):
        import highspy
        t0 = time.perf_counter()
        h = highspy.Highs()
        for key, value in self.settings.items():
            h.setOptionValue(key, value)
        h.passModel(data["lp"])
        h.passHessian(data["hessian"])
        h.run()
        seconds = time.perf_counter() - t0
        status = h.getModelStatus()
        info = h.getInfo()
        iterations = info.qp_iteration_count if self.method == "qpasm" else info.ipm_iteration_count
        solution = h.getSolution()
        d = np.array(solution.col_value) if solution.value_valid else None
        lam = np.array(solution.row_dual) if solution.dual_valid else None
        return Outcome(seconds, d, lam, iterations, h.modelStatusToString(status),
                       status == highspy.HighsModelStatus.kOptimal)


# HiGHS' other QP method, its interior point HiPO ("hipo"), is not built into the PyPI
# wheel of highspy 1.16 (it says "The following features are unavailable: amd, blas,
# metis, rcm" and runs the active-set method instead): Highs("hipo") would measure qpasm.
SOLVERS = [Piqp(), Clarabel(), Osqp(), Proxsuite(), ProxsuiteDense(), Qpalm(), Daqp(),
           Quadprog(), Cvxopt(), Highs("qpasm")]


# --------------------------------------------------------------------------------------
# Measurement


def measure(solver, problem, data, start, repeats, report_first):
    """Solves up to `repeats` times; returns (median seconds, runs, last outcome)."""
    first = solver.solve(data, start)
    if report_first is not None:
        report_first(first.seconds)
    times = [first.seconds]
    outcome = first
    runs = max(1, min(repeats, int(REPEAT_BUDGET / max(first.seconds, 1e-9))))
    for _ in range(runs - 1):
        outcome = solver.solve(data, start)
        times.append(outcome.seconds)
    return statistics.median(times), len(times), outcome


def accuracy(problem, y, outcome, reference):
    """(‖x − x_ref‖∞, ‖λ − λ_ref‖∞, max violation) of an outcome, NaN where unknown."""
    if outcome.d is None or not np.all(np.isfinite(outcome.d)):
        return math.nan, math.nan, math.nan
    x = y + outcome.d
    violation = problem.max_violation(x)
    if reference is None:
        return math.nan, math.nan, violation
    x_err = float(np.max(np.abs(x - reference["x"]))) if problem.n else 0.0
    lam_err = math.nan
    if outcome.lam is not None and outcome.lam.shape == reference["multipliers"].shape:
        lam_err = float(np.max(np.abs(outcome.lam - reference["multipliers"]))) if problem.m else 0.0
    return x_err, lam_err, violation


def run_pair(problem, solver, references, repeats, send):
    """Everything measured for one (problem, solver); runs in a child process."""
    row = {}
    reference, perturbed_reference, perturbed_y = references
    for module in solver.imports:  # so that no timed solve pays for an import
        importlib.import_module(module)
    r = problem.rhs(problem.y)
    data = solver.prepare(problem, r)

    def first_cold(seconds):
        send({"first": seconds})

    seconds, runs, outcome = measure(solver, problem, data, None, repeats, first_cold)
    x_err, lam_err, violation = accuracy(problem, problem.y, outcome, reference)
    row.update(cold_ms=seconds * 1e3, cold_runs=runs, cold_iterations=outcome.iterations,
               cold_status=outcome.status, cold_solved=outcome.solved, x_err=x_err,
               lam_err=lam_err, max_violation=violation)
    if not outcome.solved and seconds > 0.8 * FIRST_SOLVE_LIMIT:
        # The solver's own time limit (HiGHS): counted as a time-out.
        row["timed_out"] = True
        row["note"] = "stopped by the solver's time limit"
        return row
    if seconds > WARM_LIMIT:
        row["warm_note"] = f"cold solve > {WARM_LIMIT:.0f} s: perturbed and warm solves not measured"
        return row

    if perturbed_y is None:
        row["note"] = "no perturbed problem in the reference folder: warm part skipped"
        return row
    r_perturbed = problem.rhs(perturbed_y)
    data = solver.prepare(problem, r_perturbed)
    seconds, runs, outcome = measure(solver, problem, data, None, repeats, None)
    x_err, _, violation = accuracy(problem, perturbed_y, outcome, perturbed_reference)
    row.update(pert_cold_ms=seconds * 1e3, pert_cold_iterations=outcome.iterations,
               pert_cold_status=outcome.status, pert_x_err=x_err,
               pert_max_violation=violation)

    if solver.warm_reason is not None:
        row["warm_note"] = solver.warm_reason
        return row
    if reference is None:
        row["warm_note"] = "no reference answer to start from"
        return row
    start = solver.start(data, reference["x"] - perturbed_y, reference["multipliers"])
    seconds, runs, outcome = measure(solver, problem, data, start, repeats, None)
    x_err, _, violation = accuracy(problem, perturbed_y, outcome, perturbed_reference)
    row.update(warm_ms=seconds * 1e3, warm_iterations=outcome.iterations,
               warm_status=outcome.status, warm_x_err=x_err, warm_max_violation=violation)
    return row


def child_main(problem, solver, references, repeats, conn):
    # Solvers that print banners (HiGHS) write to the child's stdout: silence it.
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    try:
        row = run_pair(problem, solver, references, repeats, conn.send)
        conn.send({"row": row})
    except Exception:  # reported in the row, so that the run goes on
        conn.send({"row": {"cold_status": "error", "note": traceback.format_exc(limit=3)}})
    conn.close()


def run_in_child(problem, solver, references, repeats):
    """Runs `run_pair` in a forked child, with the time limits; returns the row."""
    context = multiprocessing.get_context("fork")
    parent_conn, child_conn = context.Pipe(duplex=False)
    process = context.Process(target=child_main,
                              args=(problem, solver, references, repeats, child_conn))
    process.start()
    child_conn.close()
    row = None
    started = time.monotonic()
    first_seen = False
    try:
        while True:
            limit = FIRST_SOLVE_LIMIT if not first_seen else CHILD_LIMIT
            remaining = limit - (time.monotonic() - started)
            if remaining <= 0 or not parent_conn.poll(remaining):
                what = (f"first solve > {FIRST_SOLVE_LIMIT:.0f} s" if not first_seen
                        else f"all solves > {CHILD_LIMIT:.0f} s")
                row = {"cold_status": "timeout", "note": f"stopped: {what}"}
                break
            message = parent_conn.recv()
            if "first" in message:
                first_seen = True
            if "row" in message:
                row = message["row"]
                break
    except EOFError:
        row = {"cold_status": "crashed", "note": f"child exit code {process.exitcode}"}
    finally:
        if process.is_alive():
            process.kill()
        process.join()
    if row.get("cold_status") == "crashed" or process.exitcode not in (0, None, -9):
        row.setdefault("note", f"child exit code {process.exitcode}")
    return row


COLUMNS = ["problem", "rows", "unknowns", "solver", "ref_backend", "cold_ms", "cold_runs",
           "cold_iterations", "cold_status", "cold_solved", "x_err", "lam_err",
           "max_violation", "pert_cold_ms", "pert_cold_iterations", "pert_cold_status",
           "pert_x_err", "pert_max_violation", "pert_ref_backend", "warm_ms",
           "warm_iterations", "warm_status", "warm_x_err", "warm_max_violation",
           "warm_note", "note", "settings"]


def run(args):
    chosen = SOLVERS
    if args.solvers:
        wanted = args.solvers.split(",")
        chosen = [s for s in SOLVERS if s.name in wanted]
    available = []
    for solver in chosen:
        try:
            __import__(solver.module)
            available.append(solver)
        except ImportError:
            print(f"{solver.name}: package {solver.module} missing, skipped", file=sys.stderr)
    timed_out = {}  # solver name -> (rows, unknowns) of the smallest problem it timed out on
    with open(args.out, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        problems = sorted((Problem(path) for path in args.qp), key=lambda p: (p.m, p.n))
        for problem in problems:
            reference = load_reference(args.refs, problem.name)
            perturbed_reference = load_reference(args.refs, f"{problem.name}_perturbed")
            perturbed_path = Path(args.refs) / f"{problem.name}_perturbed.json"
            perturbed_y = None
            if perturbed_path.exists():
                perturbed_y = np.array(json.loads(perturbed_path.read_text())["y"], dtype=float)
                if not np.allclose(perturbed_y, problem.perturbed_y(), rtol=0, atol=1e-12):
                    print(f"{problem.name}: the perturbed file differs from this script's "
                          "perturbation (seed?); using the file", file=sys.stderr)
            references = (reference, perturbed_reference, perturbed_y)
            for solver in available:
                base = {"problem": problem.name, "rows": problem.m, "unknowns": problem.n,
                        "solver": solver.name,
                        "ref_backend": reference["backend"] if reference else "none",
                        "pert_ref_backend": (perturbed_reference["backend"]
                                             if perturbed_reference else "none"),
                        "settings": json.dumps(solver.settings)}
                smallest = timed_out.get(solver.name)
                if smallest and problem.m >= smallest[0] and problem.n >= smallest[1]:
                    row = {"cold_status": "skipped",
                           "note": "timed out on a smaller problem"}
                else:
                    row = run_in_child(problem, solver, references, args.repeats)
                    if row.get("cold_status") == "timeout" or row.get("timed_out"):
                        timed_out[solver.name] = (problem.m, problem.n)
                row.update(base)
                writer.writerow({k: format_value(row.get(k, "")) for k in COLUMNS})
                handle.flush()
                print(f"{problem.name:32s} {solver.name:12s} "
                      f"cold {format_value(row.get('cold_ms', ''))} ms "
                      f"it {row.get('cold_iterations', '')} "
                      f"x_err {format_value(row.get('x_err', ''))} "
                      f"viol {format_value(row.get('max_violation', ''))} "
                      f"warm {format_value(row.get('warm_ms', ''))} ms "
                      f"[{row.get('cold_status', '')}] {row.get('note', '')}", flush=True)


def format_value(value):
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return f"{value:.4g}"
    return value


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    perturb = commands.add_parser("perturb", help="write the perturbed problems")
    perturb.add_argument("refs", help="folder for STEM_perturbed.json")
    perturb.add_argument("qp", nargs="+", help="recorded QP JSON files")
    measure_cmd = commands.add_parser("run", help="measure the solvers")
    measure_cmd.add_argument("--refs", required=True,
                             help="folder with STEM_ref.json, STEM_perturbed.json and "
                                  "STEM_perturbed_ref.json")
    measure_cmd.add_argument("--out", required=True, help="CSV file to write")
    measure_cmd.add_argument("--solvers", default="",
                             help="comma-separated subset of: "
                                  + ",".join(s.name for s in SOLVERS))
    measure_cmd.add_argument("--repeats", type=int, default=5)
    measure_cmd.add_argument("qp", nargs="+", help="recorded QP JSON files")
    args = parser.parse_args()
    if args.command == "perturb":
        write_perturbed(args.qp, args.refs)
    else:
        run(args)


if __name__ == "__main__":
    main()
