"""A body from a tape measure: the hm08 body model (shape_model.py) fitted to measurements.

Unknowns: the macro weight and height, the cup size (women) and the local modifier of
each measurement given (the neck's also scales its width and depth), as the weights of
its -incr and -decr targets; the modifiers of measurements not given stay at the prior.
Every requested measurement is a residual (measured - requested) / 0.1 cm, taken exactly
as ``body_measurements`` takes it; a small Tikhonov term keeps the local modifiers and the
cup size near a prior, and a smaller one the macros, so measurements that are not given
follow the prior (the base sample body of that gender). Bounded Gauss-Newton: each step
linearises the measurements through their tapes (measured once per step, re-taken on
every probed shape in well under a millisecond), solves the bounded linear least-squares
problem, and measures the new body afresh; a step that does not lower the objective is
halved.

A measurement that cannot be met within 0.5 cm is reported with the reason: a model
parameter at the end of its range (the value lies beyond the bodies the model can make),
or, with every parameter inside its range, the measurements contradict each other. A
value whose own modifier ends at its limit is then weighted 30 times less and the fit
goes on, so that it does not pull the others (the height, say) off.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import SeamfitError
from .io import Body
from .measure import MEASUREMENTS, body_measurements
from .measurement_sets import MeasurementSet, check_measurements
from .shape_model import LOCAL_MODIFIERS, ShapeParameters, _split, hm08_faces, hm08_landmarks, shape_vertices

__all__ = ["MeasuredBody", "from_measurements"]

TOLERANCE_CM = 0.5          # the promise: every given measurement within this
GOAL_CM = 0.1               # the fit stops once every given measurement is this close
SIGMA_CM = 0.1              # residual scale
SOFT_SIGMA_CM = 3.0         # residual scale of a value the model cannot reach
LOCAL_PRIOR_WEIGHT = 0.3    # Tikhonov weight of a local modifier / the cup size (per unit)
MACRO_PRIOR_WEIGHT = 0.002  # and of the macro weight and height
MAX_STEPS = 12
MAX_MEASURES = 12          # full measurements per fit (about 0.25 s each): bounds the time
STEP = 1e-3                 # finite-difference step of a parameter

# The priors: the parameters of the base sample bodies (women_size06 and men_medium of
# sample_files/bodies/measurements.json), so that no measurement at all gives them back.
PRIORS = {
    "female": ShapeParameters(gender=0.0, weight=0.4372, height=0.5294, cupsize=0.4044, local={
        "bust": 0.1986, "underbust": 0.147, "waist": -0.3124, "hip": 0.0696, "shoulder": 0.2793,
        "nape_to_waist": 0.1764, "waist_to_hip": 0.0529, "upper_arm": 0.3791, "thigh": -0.0087,
        "neck": 0.6223, "neck_horiz": 0.3461, "neck_depth": 0.2927}),
    "male": ShapeParameters(gender=1.0, weight=0.7608, height=0.5213, cupsize=0.5, local={
        "bust": -0.1744, "underbust": 0.0189, "waist": 0.414, "hip": 0.1227, "shoulder": 0.4268,
        "nape_to_waist": 0.1911, "waist_to_hip": 0.0517, "upper_arm": -0.1487, "thigh": -0.2583,
        "neck": 0.0373, "neck_horiz": 0.0242, "neck_depth": 0.0151}),
}


@dataclass
class MeasuredBody:
    """A body made from measurements, and how well it meets them."""

    body: Body
    gender: str
    requested: dict                 # cm, the measurements given
    achieved: dict                  # cm, every measurement of the body
    shape: ShapeParameters
    seconds: float
    steps: int
    problems: list = field(default_factory=list)   # one line per measurement not met, with why

    @property
    def set(self) -> list:
        return [k for k in MEASUREMENTS if k in self.requested]

    @property
    def inferred(self) -> list:
        return [k for k in MEASUREMENTS if k not in self.requested]

    @property
    def errors(self) -> dict:
        return {k: self.achieved[k] - v for k, v in self.requested.items()}

    @property
    def max_error_cm(self) -> float:
        return max((abs(e) for e in self.errors.values()), default=0.0)

    @property
    def met(self) -> bool:
        return not self.problems

    def report(self) -> dict:
        r2 = lambda d: {k: round(float(v), 2) for k, v in d.items()}
        return {"name": self.body.name, "gender": self.gender, "set": self.set, "inferred": self.inferred,
                "requested_cm": r2(self.requested), "achieved_cm": r2(self.achieved),
                "error_cm": r2(self.errors), "max_error_cm": round(self.max_error_cm, 3),
                "met": self.met, "tolerance_cm": TOLERANCE_CM, "problems": list(self.problems),
                "model_parameters": self.shape.as_dict(), "fit": {"steps": self.steps,
                                                                   "seconds": round(self.seconds, 3)},
                "n_vertices": self.body.n_vertices, "n_faces": self.body.n_faces}


# The local modifiers that serve each measurement; those of measurements not given stay
# at the prior, so the body there is the model's.
SERVES = {"neck": ("neck", "neck_horiz", "neck_depth")}


class _Parameters:
    """The fitted parameters as a vector, with their ranges and prior. A local modifier is
    two parameters, the weights of its -incr and -decr targets (each in [0, 1]): the body
    is linear in each, where a signed value would put a kink at 0."""

    def __init__(self, gender: str, keys):
        self.prior_shape = PRIORS[gender]
        free = [m for k in keys for m in SERVES.get(k, (k,)) if k != "height"]
        self.locals = [m for m in LOCAL_MODIFIERS if m in free]
        self.names = ["weight", "height"] + (["cupsize"] if gender == "female" else []) + \
            [f"{m}{side}" for m in self.locals for side in "+-"]
        self.lo = np.zeros(len(self.names))
        self.hi = np.ones(len(self.names))
        self.prior = self.vector(self.prior_shape)
        self.weight = np.array([MACRO_PRIOR_WEIGHT if n in ("weight", "height") else LOCAL_PRIOR_WEIGHT
                                for n in self.names])

    def at_limit(self, key: str, x) -> bool:
        """Whether the measurement's own modifier (the macro height for the height) is at
        the end of its range."""
        if key == "height":
            v = x[self.names.index("height")]
            return v <= 1e-3 or v >= 1 - 1e-3
        return any(x[self.names.index(m + side)] >= 1 - 1e-3 for m in SERVES.get(key, (key,))
                   for side in "+-" if m + side in self.names)

    def vector(self, s: ShapeParameters) -> np.ndarray:
        values = {"weight": s.weight, "height": s.height, "cupsize": s.cupsize}
        for m in self.locals:        # a signed value, or both targets on at once (see shape())
            values[m + "+"], values[m + "-"] = _split(s.local.get(m, 0.0))
        return np.array([values[n] for n in self.names])

    def shape(self, x: np.ndarray) -> ShapeParameters:
        d = dict(zip(self.names, map(float, x)))
        local = {k: self.prior_shape.local.get(k, 0.0) for k in LOCAL_MODIFIERS}
        for m in self.locals:
            up, down = d[m + "+"], d[m + "-"]
            local[m] = up - down if min(up, down) < 1e-9 else (up, down)
        return ShapeParameters(gender=self.prior_shape.gender, weight=d["weight"], height=d["height"],
                               cupsize=d.get("cupsize", self.prior_shape.cupsize), local=local)


def from_measurements(measurements, gender: str | None = None, name: str | None = None) -> MeasuredBody:
    """Fit the body model to ``measurements``: a dict of cm by seamfit's names
    (``seamfit.body.MEASUREMENTS``; any subset), a :class:`MeasurementSet`, or a measurement
    file holding one body. Raises :class:`MeasurementError` for values that cannot make a
    body; a fit that misses a value by more than 0.5 cm says why in ``problems``."""
    t0 = time.perf_counter()
    mset = _as_set(measurements)
    gender = gender or mset.gender
    if gender not in PRIORS:
        raise SeamfitError(f"gender must be 'female' or 'male', got {gender!r}")
    requested = check_measurements(mset.cm, mset.where)
    keys = [k for k in MEASUREMENTS if k in requested]
    target = np.array([requested[k] for k in keys])
    p = _Parameters(gender, keys)
    lm = hm08_landmarks()
    faces = hm08_faces()

    def measure(x):
        body = Body(shape_vertices(p.shape(x)), faces, name=name or mset.name)
        return body, body_measurements(body, lm, tapes=True)

    def objective(m, x, sigma):
        r = (np.array([m[k] for k in keys]) - target) / sigma
        return float(r @ r + np.sum((p.weight * (x - p.prior)) ** 2))

    def tape_objective(m, x, sigma):
        """The objective with the measurements re-taken by m's tapes: no slicing."""
        lengths = _tape_lengths(m["tapes"], keys, shape_vertices(p.shape(x), place=False))
        return objective(dict(zip(keys, lengths)), x, sigma)

    measures = [1]                               # full measurements taken, the costly part

    def solve(x, body, m, sigma, max_steps):
        """Bounded Gauss-Newton from x; returns the last accepted x, its body, measurements
        and the number of steps."""
        f = objective(m, x, sigma)
        steps = 0
        while steps < max_steps and measures[0] < MAX_MEASURES:
            if max((abs(m[k] - v) for k, v in zip(keys, target)), default=0.0) < GOAL_CM:
                break
            steps += 1
            dx = _gauss_newton_step(p, x, m, keys, target, sigma)
            # Shorten the step on the tapes first (cheap), then measure where it lands;
            # halve on full measurements only if the tapes were wrong.
            for _ in range(6):
                if tape_objective(m, np.clip(x + dx, p.lo, p.hi), sigma) < f:
                    break
                dx *= 0.5
            for _ in range(3):
                x_new = np.clip(x + dx, p.lo, p.hi)
                body_new, m_new = measure(x_new)
                measures[0] += 1
                f_new = objective(m_new, x_new, sigma)
                if f_new < f:
                    break
                dx *= 0.5
            else:
                break
            stalled = f - f_new < 1e-4 * f           # out of range: the rest would not help
            x, body, m, f = x_new, body_new, m_new, f_new
            if stalled:
                break
        return x, body, m, steps

    x = p.prior.copy()
    body, m = measure(x)
    sigma = np.full(len(keys), SIGMA_CM)
    x, body, m, steps = solve(x, body, m, sigma, MAX_STEPS)
    missed = np.array([abs(m[k] - v) > TOLERANCE_CM and p.at_limit(k, x) for k, v in zip(keys, target)])
    if missed.any() and not missed.all():
        # Values out of the model's reach would pull the others off (a girth beyond the
        # range taking the height with it): they become soft, the rest are met.
        sigma[missed] = SOFT_SIGMA_CM
        x, body, m, more = solve(x, body, m, sigma, 4)
        steps += more
    achieved = {k: float(m[k]) for k in MEASUREMENTS}
    result = MeasuredBody(body=body, gender=gender, requested=requested, achieved=achieved,
                          shape=p.shape(x), seconds=time.perf_counter() - t0, steps=steps)
    result.problems = _problems(p, x, result)
    body.meta["measurements"] = result.report()
    return result


def _as_set(measurements) -> MeasurementSet:
    from pathlib import Path
    from .measurement_sets import MeasurementError, load_measurement_sets

    if isinstance(measurements, MeasurementSet):
        return measurements
    if isinstance(measurements, (str, Path)):
        sets = load_measurement_sets(measurements)
        if len(sets) != 1:
            raise MeasurementError(f"{measurements}: holds {len(sets)} bodies ({', '.join(s.name for s in sets)});"
                                   " make each from its MeasurementSet (load_measurement_sets)")
        return sets[0]
    if isinstance(measurements, dict):
        return MeasurementSet(dict(measurements))
    raise SeamfitError(f"measurements must be a dict of cm, a MeasurementSet or a file, "
                       f"not {type(measurements).__name__}")


def _tape_lengths(tapes: dict, keys: list, V: np.ndarray) -> np.ndarray:
    return np.array([tapes[k].length(V) for k in keys])


def _gauss_newton_step(p: _Parameters, x, m: dict, keys: list, target, sigma) -> np.ndarray:
    """The bounded Gauss-Newton step: measurements linearised through their tapes."""
    from scipy.optimize import lsq_linear      # here: importing seamfit.body stays light
    tapes = m["tapes"]
    V0 = shape_vertices(p.shape(x), place=False)
    base = _tape_lengths(tapes, keys, V0)
    J = np.empty((len(keys), len(x)))
    for i in range(len(x)):
        h = STEP if x[i] + STEP <= p.hi[i] else -STEP          # probe inside the range
        xi = x.copy()
        xi[i] += h
        J[:, i] = (_tape_lengths(tapes, keys, shape_vertices(p.shape(xi), place=False)) - base) / h
    r = (np.array([m[k] for k in keys]) - target) / sigma
    A = np.vstack([J / sigma[:, None], np.diag(p.weight)])
    b = np.concatenate([-r, -p.weight * (x - p.prior)])
    return lsq_linear(A, b, bounds=(p.lo - x, p.hi - x), method="bvls").x


def _problems(p: _Parameters, x, result: MeasuredBody) -> list:
    """Why each measurement missed by more than the tolerance is missed: the macros and
    the measurement's own modifier that end at their limit in the direction the value
    needs, else the other measurements' pull."""
    out = []
    for key, err in result.errors.items():
        if abs(err) <= TOLERANCE_CM:
            continue
        grow = err < 0                           # the body needs more of this measurement
        macros = [f"macro {n} at {1 if grow else 0}" for n, v in zip(p.names, x)
                  if n[-1] not in "+-" and (v >= 1 - 1e-3 if grow else v <= 1e-3)]
        side = "+" if grow else "-"
        own = [f"the {m} modifier at {side}1" for m in SERVES.get(key, (key,))
               if m + side in p.names and x[p.names.index(m + side)] >= 1 - 1e-3]
        line = (f"{key}: requested {result.requested[key]:.1f} cm, achieved {result.achieved[key]:.1f} cm "
                f"({err:+.1f})")
        if own or macros:
            line += f": out of the model's range ({', '.join(own + macros)})"
        else:
            line += ": inconsistent with the other measurements (the model cannot meet them together)"
        out.append(line)
    return out
