"""The MPC step on the host (issue 47): the real-time iteration of cpp/include/ipgen_mpc.h beside
a dense active-set QP (DAQP, condensed), OSQP (ADMM, sparse) and IPOPT (the whole NLP).

    .venv/bin/python -m bench.mpc [--seconds S] [--out FILE]

The QUBE-Servo 2 preset (u in volts, ±10 V, the arm within ±1 rad), N = 30, T = 10 ms, Q = diag(1,
10, 0.1, 0.1), R = 0.1, P the discrete LQR's: a closed loop of the real-time iteration (RTI) on
the exact model (scipy's solve_ivp between samples) from θ = (0.5, 0.15) rad, θ̇ = (1, 0) rad/s,
which drives u to its bound and the arm to its travel. At every sample:

1. the C step (`ipgen_mpc_step` through ctypes: the linearisation, RK4 with its sensitivities at
   30 stages, and the interior-point QP on the Riccati recursion), timed around the call;
2. the QP that step solved (read back from its workspace: the linearisation, the guess and the
   step) solved again by DAQP on the condensed problem (30 inputs, the arm's travel as 30
   general rows; warm-started with the last active set) and by OSQP on the sparse one (states
   and inputs, the dynamics as equalities; set up once, updated and warm-started each sample;
   eps 1e-6 and 1e-3), timed around the solver's call only (condensing is not timed: numpy),
   with their first input's distance to the interior point's;
3. every 10th sample, IPOPT on the whole NLP (tests/mpc_reference.py), cold and warm-started.

Also the step with one interior-point iteration (the linearisation's share), the converged
mode (`solve`), and the same closed loop in C alone (tests/c/mpc_qube_loop.c on the generated C
header, double and float, 150 samples: the firmware path without Python).
Writes docs/bench/mpc.md (needs osqp and daqp: the extra `bench`).
"""

from __future__ import annotations

import argparse
import ctypes
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench.report import ROOT, compiler_version, machine, table, version

sys.path.insert(0, str(ROOT / "tests"))

OUT = ROOT / "docs" / "bench" / "mpc.md"
# The section this script writes in --out (docs/bench/mpc.md), which bench.mpc_m4 and prose share
BEGIN, END = "<!-- bench.mpc: begin -->", "<!-- bench.mpc: end -->"


def us(values: list[float]) -> str:
    """median (max) in microseconds."""
    return f"{1e6 * statistics.median(values):.0f} ({1e6 * max(values):.0f})"


def qp_of(c: object, x: np.ndarray) -> dict[str, np.ndarray]:
    """The QP the last step solved, from its workspace: guess traj0, A_k, B_k, d_k, the IPM's step z."""
    nx, nu, N = c.nx, c.nu, c.N  # type: ignore[attr-defined]
    w = c.work.astype(float)  # type: ignore[attr-defined]
    Z = (N + 1) * nx + N * nu
    o = 1
    traj = w[o : o + Z]
    o += Z
    A = w[o : o + N * nx * nx].reshape(N, nx, nx)
    o += N * nx * nx
    B = w[o : o + N * nx * nu].reshape(N, nx, nu)
    o += N * nx * nu
    d = w[o : o + N * nx].reshape(N, nx)
    o += N * nx
    z = w[o : o + Z]
    return {"traj0": traj - z, "A": A, "B": B, "d": d, "z": z, "x": x}


def condensed(c: object, q: dict[str, np.ndarray]) -> tuple[np.ndarray, ...]:
    """(H, f, A, upper, lower) of the QP in the inputs alone (DAQP's form: the first N entries of
    the bounds are the inputs' simple bounds, then the arm's travel at x_1..x_N)."""
    nx, N = c.nx, c.N  # type: ignore[attr-defined]
    traj0 = q["traj0"]
    xs, u0 = traj0[: (N + 1) * nx].reshape(N + 1, nx), traj0[(N + 1) * nx :]
    # dx_k = free_k + sum_j G[k, j] du_j
    free = np.zeros((N + 1, nx))
    free[0] = q["x"] - xs[0]
    G = np.zeros((N + 1, nx, N))
    for k in range(N):
        free[k + 1] = q["A"][k] @ free[k] + q["d"][k]
        G[k + 1] = q["A"][k] @ G[k]
        G[k + 1][:, k] += q["B"][k][:, 0]
    H = 2 * c.R[0, 0] * np.eye(N)  # type: ignore[attr-defined]
    f = 2 * c.R[0, 0] * u0  # type: ignore[attr-defined]
    for k in range(1, N + 1):
        W = c.P if k == N else c.Q  # type: ignore[attr-defined]
        H += 2 * G[k].T @ W @ G[k]
        f += 2 * G[k].T @ W @ (xs[k] + free[k] - c.x_ref)  # type: ignore[attr-defined]
    rows = G[1:, 0, :]  # the arm angle's rows
    offset = xs[1:, 0] + free[1:, 0]
    upper = np.concatenate([c.u_max - u0, 1.0 - offset])  # type: ignore[attr-defined]
    lower = np.concatenate([c.u_min - u0, -1.0 - offset])  # type: ignore[attr-defined]
    return H, f, rows, upper, lower


class SparseOsqp:
    """OSQP on the sparse QP: w = (dx_1..dx_N, du_0..du_{N-1}); set up on the first QP, then updated."""

    def __init__(self, c: object, eps: float) -> None:
        self.c, self.eps, self.solver = c, eps, None

    def matrices(self, q: dict[str, np.ndarray]) -> tuple[object, ...]:
        import scipy.sparse as sp

        c = self.c
        nx, N = c.nx, c.N  # type: ignore[attr-defined]
        n = N * nx + N
        traj0 = q["traj0"]
        xs, u0 = traj0[: (N + 1) * nx].reshape(N + 1, nx), traj0[(N + 1) * nx :]
        blocks = [2 * c.Q] * (N - 1) + [2 * c.P]  # type: ignore[attr-defined]
        P = sp.block_diag([*blocks, 2 * c.R[0, 0] * sp.eye(N)], format="csc")  # type: ignore[attr-defined]
        # W = 2 Q, 2 P already
        grad = np.concatenate([W @ (xs[k + 1] - c.x_ref) for k, W in enumerate(blocks)])  # type: ignore[attr-defined]
        grad = np.concatenate([grad, 2 * c.R[0, 0] * u0])  # type: ignore[attr-defined]
        Aeq = sp.lil_matrix((N * nx, n))
        beq = np.zeros(N * nx)
        dx0 = q["x"] - xs[0]
        for k in range(N):
            Aeq[k * nx : (k + 1) * nx, k * nx : (k + 1) * nx] = -np.eye(nx)
            if k > 0:
                Aeq[k * nx : (k + 1) * nx, (k - 1) * nx : k * nx] = q["A"][k]
            Aeq[k * nx : (k + 1) * nx, N * nx + k] = q["B"][k]
            beq[k * nx : (k + 1) * nx] = -q["d"][k] - (q["A"][0] @ dx0 if k == 0 else 0)
        bounds = sp.lil_matrix((2 * N, n))
        for k in range(N):
            bounds[k, N * nx + k] = 1.0
            bounds[N + k, k * nx] = 1.0
        A = sp.vstack([Aeq, bounds], format="csc")
        lower = np.concatenate([beq, c.u_min - u0, -1.0 - xs[1:, 0]])  # type: ignore[attr-defined]
        upper = np.concatenate([beq, c.u_max - u0, 1.0 - xs[1:, 0]])  # type: ignore[attr-defined]
        return P, grad, A, lower, upper

    def solve(self, q: dict[str, np.ndarray]) -> tuple[float, float]:
        """(seconds of the solve call, du_0)."""
        import osqp

        P, grad, A, lower, upper = self.matrices(q)
        previous = self.solver
        self.solver = osqp.OSQP()  # set up again (a zero entry of A_k would change the sparsity), untimed
        self.solver.setup(P, grad, A, lower, upper, eps_abs=self.eps, eps_rel=self.eps, verbose=False,
                          max_iter=100000, polish=False)  # fmt: skip
        if previous is not None:  # warm start: the last solution and multipliers
            self.solver.warm_start(x=self.x, y=self.y)
        start = time.perf_counter()
        result = self.solver.solve()
        seconds = time.perf_counter() - start
        self.x, self.y = result.x, result.y
        nx, N = self.c.nx, self.c.N  # type: ignore[attr-defined]
        return seconds, float(result.x[N * nx])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="closed-loop time simulated [s]")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()

    import daqp
    from mpc_reference import IpoptReference
    from scipy.integrate import solve_ivp

    import ipgen
    from ipgen.control.linear import vector_field

    p = ipgen.Pendulum.preset("qube_servo2")
    design = {"u_max": 10.0, "travel": 1.0, "Q": [1, 10, 0.1, 0.1], "R": 0.1, "horizon": 30, "period": 0.01}
    c = ipgen.mpc(p, **design)
    single = ipgen.mpc(p, **design, qp_iterations=1)
    converged = ipgen.mpc(p, **design, mode="converged")
    reference = IpoptReference(c)
    field = vector_field(p.replace(positive="clockwise"))
    lib, settings = c._lib, ctypes.byref(c._settings)
    u_buffer = np.zeros(1)
    osqp_tight, osqp_loose = SparseOsqp(c, 1e-6), SparseOsqp(c, 1e-3)
    x = np.array([0.5, 0.15, 1.0, 0.0])
    names = ("step", "single", "daqp", "daqp_empty", "osqp6", "osqp3", "ipopt", "ipopt_warm", "converged",
             "qp_iterations")  # fmt: skip
    rows: dict[str, list[float]] = {k: [] for k in names}
    errors: dict[str, list[float]] = {"daqp": [], "osqp6": [], "osqp3": [], "ipopt": []}
    sense = np.zeros(2 * c.N, dtype=np.int32)
    previous: np.ndarray | None = None
    steps = round(args.seconds / c.period)
    for k in range(steps):
        state = np.ascontiguousarray(x)
        start = time.perf_counter()
        lib.ipgen_mpc_step(
            settings, state.ctypes.data, u_buffer.ctypes.data, c.work.ctypes.data, ctypes.byref(c._info)
        )
        rows["step"].append(time.perf_counter() - start)
        u = float(u_buffer[0])
        rows["qp_iterations"].append(c._info.qp_iterations)
        q = qp_of(c, x)
        du_ipm = q["z"][(c.N + 1) * c.nx]
        H, f, A, upper, lower = condensed(c, q)
        start = time.perf_counter()
        solution, _, flag, _ = daqp.solve(H, f, A, upper, lower, sense)
        rows["daqp"].append(time.perf_counter() - start)
        if flag >= 1:
            errors["daqp"].append(abs(solution[0] - du_ipm))
        one = (np.eye(1), np.zeros(1), np.zeros((0, 1)), np.ones(1), -np.ones(1), np.zeros(1, dtype=np.int32))
        start = time.perf_counter()
        daqp.solve(*one)
        rows["daqp_empty"].append(time.perf_counter() - start)
        # the active set found, shifted by one sample, warm-starts the next DAQP solve
        active = (np.abs(A @ solution - upper[c.N :]) < 1e-9) | (np.abs(A @ solution - lower[c.N :]) < 1e-9)
        bound = (np.abs(solution - upper[: c.N]) < 1e-9) | (np.abs(solution - lower[: c.N]) < 1e-9)
        sense = np.concatenate([np.roll(bound, -1), np.roll(active, -1)]).astype(np.int32)
        for name, solver in (("osqp6", osqp_tight), ("osqp3", osqp_loose)):
            seconds, du = solver.solve(q)
            rows[name].append(seconds)
            errors[name].append(abs(du - du_ipm))
        if k % 10 == 0:
            start = time.perf_counter()
            u_ipopt, inputs = reference.solve(x)
            rows["ipopt"].append(time.perf_counter() - start)
            if previous is not None:  # the last solution's inputs shifted by a sample
                warm = (np.tile(x, c.N + 1), np.append(previous[1:], previous[-1]))
                start = time.perf_counter()
                reference.solve(x, warm=warm)
                rows["ipopt_warm"].append(time.perf_counter() - start)
            previous = inputs
            start = time.perf_counter()
            u_converged = converged.solve(x)
            rows["converged"].append(time.perf_counter() - start)
            errors["ipopt"].append(abs(u_converged - u_ipopt))
        single.reset()
        single.step(x)  # cold: its first step runs the cold iterations; time the warm one next
        start = time.perf_counter()
        single.step(x)
        rows["single"].append(time.perf_counter() - start)
        x = solve_ivp(lambda _, s, v=u: field.f(s, v), (0.0, c.period), x, rtol=1e-10, atol=1e-12).y[:, -1]
    from test_mpc import c_loop

    with tempfile.TemporaryDirectory() as scratch:  # the firmware path, without Python
        c_seconds = {
            scalar: min(c_loop(c, [0.5, 0.15, 1.0, 0.0], scalar, Path(scratch))[1] for _ in range(3))
            for scalar in ("double", "float")
        }
    warm_steps = rows["step"][1:]
    iterations = rows["qp_iterations"][1:]
    per_iteration = (statistics.median(warm_steps) - statistics.median(rows["single"])) / max(
        1.0, statistics.median(iterations) - 1
    )
    facts = {
        "C compiler": compiler_version("gcc") + " (the MPC library: -std=c99 -O2)",
        "daqp": version("daqp"),
        "osqp": version("osqp"),
        "casadi": version("casadi"),
    }
    iters = f"{statistics.median(iterations):.0f} ({max(iterations)})"
    daqp_error = f"{max(errors['daqp']):.1e}" if errors["daqp"] else "–"
    results = [
        ["RTI step, C (linearisation + interior-point QP, Riccati)", us(warm_steps), "–"],
        *(
            [f"  the loop in C alone (generated header, {scalar}; mean, best of 3)", f"{1e6 * t:.0f}", "–"]
            for scalar, t in c_seconds.items()
        ),
        ["  its interior-point iterations per sample", iters, "–"],
        ["  the step with 1 interior-point iteration", us(rows["single"]), "–"],
        ["  one interior-point iteration (the difference)", f"{1e6 * per_iteration:.1f}", "–"],
        ["DAQP on the condensed QP (solve only; warm active set)", us(rows["daqp"]), daqp_error],
        ["  DAQP's Python call on a 1-variable QP (its binding's share)", us(rows["daqp_empty"]), "–"],
        *(
            [f"OSQP, sparse QP, eps {eps} (solve only; warm)", us(rows[name]), f"{max(errors[name]):.1e}"]
            for name, eps in (("osqp6", "1e-6"), ("osqp3", "1e-3"))
        ),
        ["converged mode (`solve`, cold, to 1e-10)", us(rows["converged"]), "–"],
        ["IPOPT, whole NLP, cold (tol 1e-12)", us(rows["ipopt"]), f"vs converged {max(errors['ipopt']):.1e}"],
        ["IPOPT, whole NLP, warm-started from the last solution", us(rows["ipopt_warm"]), "–"],
    ]  # fmt: skip
    lines = [
        "# MPC: the step on the host",
        "",
        "Made by `.venv/bin/python -m bench.mpc` (bench/mpc.py; what it measures is its docstring).",
        "",
        *machine(facts),
        "",
        f"QUBE-Servo 2, N = {c.N}, T = {c.period * 1e3:.0f} ms, nx = {c.nx}, nu = 1; {steps} samples of RTI "
        f"in closed loop, |u| reaching 10 V and the arm its 1 rad. Workspace {c.work.size} reals: "
        f"{c.work.size * 8} bytes in double, {c.work.size * 4} in float.",
        "",
        "Times in µs, median (max) over the samples (the RTI row without the cold first step).",
        "",
        *table(["what", "time per sample [µs]", "first input against the interior point's"], results),
        "",
        "DAQP's and OSQP's rows time the solver's call only (through their Python bindings, which add a",
        "few µs); the MPC's rows include the linearisation and the ctypes call. Condensing is not timed",
        "(numpy here): N² nx² nu / 2 + N³ nx nu² / 3 multiply-adds for the prediction matrices and the",
        "Hessian, about 4.5·10⁴ here, about five interior-point iterations' worth (docs/mpc.md). The",
        "converged mode uses the exact Hessian (docs/mpc.md). A loaded machine (see the load averages)",
        "spreads the maxima.",
    ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    section = "\n".join([BEGIN, *lines, END])
    text = args.out.read_text() if args.out.exists() else ""
    # the page's other sections (bench.mpc_m4's, the prose) stay
    kept = text.split(BEGIN)[0] + section + text.split(END, 1)[1] if BEGIN in text else section + "\n" + text
    args.out.write_text(kept)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
