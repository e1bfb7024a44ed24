"""A plain scipy output-error fit of a hybrid model: the peer a user would write.

The model is a set of modes, each with a flow f_q(t, x, u, p) and guards g(t, x, u, p) that leave
the mode when they cross zero in their direction (with an optional reset map x+ = r(t, x, u, p)).
`simulate` integrates it with scipy.integrate.solve_ivp, one call per stretch between events and
input breakpoints, the guards of the current mode as terminal events; it restarts after each event
in the target mode. `fit_output_error` wraps it in scipy.optimize.least_squares over the unknown
parameters and initial states (finite-difference Jacobian), the residual being the simulated
measured output minus the data at every sample.

Nothing here is specific to one system; examples/cascaded-tanks/scipy_reference.py uses it.
"""

from __future__ import annotations

import bisect
import dataclasses
import time
from typing import Callable, Hashable, Mapping, Sequence

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.optimize import least_squares

FALLING = -1  # the guard leaves the mode when it goes from positive to negative
RISING = 1    # ... from negative to positive


@dataclasses.dataclass(frozen=True)
class Guard:
    """Leave the current mode for `target` when g(t, x, u, p) crosses zero in `direction`."""
    func: Callable[[float, np.ndarray, float, np.ndarray], float]
    direction: int
    target: Hashable
    reset: Callable[[float, np.ndarray, float, np.ndarray], np.ndarray] | None = None  # None: x+ = x


@dataclasses.dataclass(frozen=True)
class HybridModel:
    """Flows and guards per mode, and the measured output y = output(x, p) (x: n × N states)."""
    flows: Mapping[Hashable, Callable[[float, np.ndarray, float, np.ndarray], np.ndarray]]
    guards: Mapping[Hashable, Sequence[Guard]]
    output: Callable[[np.ndarray, np.ndarray], np.ndarray]


class SampledInput:
    """u(t) from samples: zero-order hold ("zoh", the latest sample), "linear", or "cubic" (a C²
    cubic spline through the samples, scipy's CubicSpline, so a solver's error control sees no kink).

    With "zoh" and `restart` the sample times are breakpoints: the integration restarts there, so a
    step of u never falls inside a solver step, and a guard that u's step crosses fires at the sample.
    """

    KINDS = ("zoh", "linear", "cubic")

    def __init__(self, t: np.ndarray, u: np.ndarray, kind: str = "zoh", restart: bool = True):
        if kind not in self.KINDS:
            raise ValueError(f"SampledInput kind = {kind!r}: must be one of {self.KINDS}")
        self.t = np.asarray(t, dtype=float)
        self.u = np.asarray(u, dtype=float)
        self.kind = kind
        self.breakpoints = self.t[1:-1] if kind == "zoh" and restart else np.empty(0)
        self._t, self._u = self.t.tolist(), self.u.tolist()  # scalar look-ups without numpy's overhead
        if kind == "cubic":
            c = CubicSpline(self.t, self.u).c  # 4 × (N-1), highest power first
            self._c = [tuple(col) for col in c.T.tolist()]

    def __call__(self, t: float) -> float:
        last = len(self._t) - 1
        k = min(max(bisect.bisect_right(self._t, t) - 1, 0), last)
        if self.kind == "zoh" or (k == last and self.kind == "linear"):
            return self._u[k]
        if self.kind == "cubic":
            k = min(k, last - 1)
            c3, c2, c1, c0 = self._c[k]
            s = t - self._t[k]
            return ((c3 * s + c2) * s + c1) * s + c0
        t0, t1 = self._t[k], self._t[k + 1]
        return self._u[k] + (self._u[k + 1] - self._u[k]) * (t - t0) / (t1 - t0)


@dataclasses.dataclass
class SimOptions:
    rtol: float = 1e-8
    atol: float = 1e-10
    method: str = "RK45"
    max_events: int = 10000
    max_step: float = np.inf
    band: float = 1e-9       # hysteresis of a guard that starts on zero (units of the guard)


@dataclasses.dataclass
class SimResult:
    x: np.ndarray            # n × N states at the sample times
    modes: list              # the mode at each sample time
    events: list             # (t, from_mode, to_mode) per mode switch
    status: str              # "completed", "max-events" or "solver-failure: MESSAGE"

    @property
    def ok(self) -> bool:
        return self.status == "completed"


def _fired_already(guard: Guard, t, x, u, p, band: float) -> bool:
    """A guard already past zero (by more than `band`) in its direction at a restart."""
    g = guard.func(t, x, u, p)
    return g < -band if guard.direction == FALLING else g > band


def _settle(model: HybridModel, mode, t, x, u, p, events, budget, band):
    """Take the switches whose guards are already past zero; return the mode, state and budget."""
    for _ in range(len(model.guards) + 1):
        fired = next((g for g in model.guards.get(mode, ())
                      if _fired_already(g, t, x, u, p, band)), None)
        if fired is None:
            return mode, x, budget
        x = fired.reset(t, x, u, p) if fired.reset else x
        events.append((t, mode, fired.target))
        mode, budget = fired.target, budget - 1
    return mode, x, budget


def _event_functions(guards: Sequence[Guard], u: SampledInput, p, t0, x0, band):
    """The guards as terminal events; one that starts within `band` of zero (the state was just put
    on it) fires only once it is `band` past zero, so a flow tangent to it cannot chatter."""
    funcs = []
    for guard in guards:
        g0 = guard.func(t0, x0, u(t0), p)
        offset = guard.direction * band if abs(g0) <= band else 0.0
        def event(t, x, guard=guard, offset=offset):
            return guard.func(t, x, u(t), p) - offset
        event.terminal = True
        event.direction = guard.direction
        funcs.append(event)
    return funcs


def simulate(model: HybridModel, p, x0, mode0, t_eval, u: SampledInput,
             options: SimOptions = SimOptions()) -> SimResult:
    """The hybrid trajectory at t_eval (increasing, t_eval[0] the initial time)."""
    t_eval = np.asarray(t_eval, dtype=float)
    n, N = len(x0), len(t_eval)
    xs, modes, events = np.full((n, N), np.nan), [None] * N, []
    stops = np.concatenate([u.breakpoints[(u.breakpoints > t_eval[0]) & (u.breakpoints < t_eval[-1])],
                            [t_eval[-1]]])
    t, x, mode, budget = t_eval[0], np.asarray(x0, dtype=float), mode0, options.max_events
    xs[:, 0], modes[0], k = x, mode, 1  # k: the next sample to record
    for stop in stops:
        while t < stop:
            mode, x, budget = _settle(model, mode, t, x, u(t), p, events, budget, options.band)
            if budget < 0:
                return SimResult(xs, modes, events, "max-events")
            inside = t_eval[k:][t_eval[k:] <= stop]
            ask = inside if inside.size and inside[-1] == stop else np.append(inside, stop)
            flow, guards = model.flows[mode], model.guards.get(mode, ())
            sol = solve_ivp(lambda s, y: flow(s, y, u(s), p), (t, stop), x, method=options.method,
                            t_eval=ask, events=_event_functions(guards, u, p, t, x, options.band),
                            rtol=options.rtol, atol=options.atol, max_step=options.max_step)
            if sol.status < 0:
                return SimResult(xs, modes, events, f"solver-failure: {sol.message}")
            got = min(np.size(sol.t), inside.size)
            if got:
                xs[:, k:k + got], modes[k:k + got] = np.asarray(sol.y)[:, :got], [mode] * got
            k += got
            if sol.status == 1:  # a guard fired: restart in its target mode
                i = next(i for i, te in enumerate(sol.t_events) if te.size)
                guard, te, xe = guards[i], sol.t_events[i][0], sol.y_events[i][0]
                x = guard.reset(te, xe, u(te), p) if guard.reset else xe
                events.append((te, mode, guard.target))
                t, mode, budget = te, guard.target, budget - 1
                if budget < 0:
                    return SimResult(xs, modes, events, "max-events")
            else:
                t, x = stop, sol.y[:, -1]
    return SimResult(xs, modes, events, "completed")


@dataclasses.dataclass
class FitProblem:
    """What `fit_output_error` fits: the parameters and initial states in one vector θ.

    `unpack(theta) -> (p, x0)` maps θ to the model's parameter vector and initial state; `theta0` is
    the start, `lower`/`upper` its bounds.
    """
    model: HybridModel
    unpack: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    theta0: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    mode0: Hashable
    t: np.ndarray
    y: np.ndarray
    u: SampledInput
    sim: SimOptions = dataclasses.field(default_factory=SimOptions)


@dataclasses.dataclass
class FitResult:
    theta: np.ndarray
    rmse: float            # of the output error on the fitted record
    success: bool
    message: str
    simulations: int       # residual evaluations, the finite-difference Jacobians' included
    seconds: float         # wall time of the fit
    cpu_seconds: float     # CPU time of the fit (this process)


FAILED_RESIDUAL = 1e3  # the residual of every sample when a simulation fails


def residual(problem: FitProblem, theta) -> np.ndarray:
    p, x0 = problem.unpack(theta)
    sim = simulate(problem.model, p, x0, problem.mode0, problem.t, problem.u, problem.sim)
    if not sim.ok or not np.all(np.isfinite(sim.x)):
        return np.full(problem.y.shape, FAILED_RESIDUAL)
    return problem.model.output(sim.x, p) - problem.y


def fit_output_error(problem: FitProblem, diff_step: float = 1e-4, max_nfev: int | None = None,
                   verbose: int = 0) -> FitResult:
    """least_squares (trust-region reflective, bounds, finite-difference Jacobian) on `residual`."""
    start, cpu_start = time.perf_counter(), time.process_time()
    sol = least_squares(lambda th: residual(problem, th), problem.theta0,
                        bounds=(problem.lower, problem.upper), method="trf", x_scale="jac",
                        diff_step=diff_step, max_nfev=max_nfev, verbose=verbose)
    seconds, cpu_seconds = time.perf_counter() - start, time.process_time() - cpu_start
    rmse = float(np.sqrt(np.mean(sol.fun ** 2)))
    simulations = int(sol.nfev) + int(sol.njev or 0) * len(sol.x)
    return FitResult(sol.x, rmse, bool(sol.success), sol.message, simulations, seconds, cpu_seconds)


def rmse(a, b) -> float:
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))
