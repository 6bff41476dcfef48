"""The fitting costs of paper Section 6 (Eq. 11-16) over a garment x and a pattern p."""
from __future__ import annotations

from dataclasses import fields, make_dataclass

import numpy as np

from .._native import core
from ..device_arrays import Buffers, host, is_device
from ..errors import SolveError
from ._mesh import mesh_arrays

# u_i of the positional cost (Eq. 16): seams and hems (panel boundaries) set the
# garment's look, so they weigh more. With ~1.5 cm edges a 50 cm panel has roughly
# one boundary vertex per ten interior ones; 4x gives the boundary about a third of
# the positional weight.
POSITIONAL_WEIGHT_INTERIOR = 1.0
POSITIONAL_WEIGHT_BOUNDARY = 4.0


# The fitting cost terms C as the native core registers them (native/core/opt/cost_terms.hpp):
# (name, label, help) in the paper's order. Their strengths, values and evaluation counts
# go by these names.
COST_TERMS = tuple(tuple(t) for t in core().COST_TERMS)
COST_TERM_NAMES = tuple(t[0] for t in COST_TERMS)

# The regularizer terms R (Section 5.1, seamfit.opt.regularizers; R^seam, seamfit.opt.seam,
# is not in the paper): (name, label, help), R^fix and R^cur before the costs, R^seam after.
_REGULARIZERS = (("fix", "Fix", "Keeps boundary vertices near the base pattern"),
                 ("cur", "Curvature", "Keeps the shape of boundary curves"))
_SEAM = (("seam", "Seam length", "Keeps the two sides of every seam equally long"),)

# What each term keeps, by strength name: (label, help), for the command line and the
# add-on's Costs panel; in the paper's order.
STRENGTH_HELP = {name: (label, text) for name, label, text in (*_REGULARIZERS, *COST_TERMS, *_SEAM)}

# The strengths' names in the paper's order, for the command line and the add-on.
STRENGTH_NAMES = tuple(STRENGTH_HELP)


class _StrengthsBase:
    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if not np.isfinite(v) or v < 0:
                raise ValueError(f"strength {f.name} must be finite and >= 0, got {v}")

    @classmethod
    def from_any(cls, s) -> "Strengths":
        if isinstance(s, cls):
            return s
        if isinstance(s, dict):
            return cls(**s)
        if hasattr(s, "strengths"):
            return cls.from_any(s.strengths)
        raise TypeError(f"cannot read strengths from {type(s).__name__}")


# One field per name of STRENGTH_NAMES, each 0 unless given: a term that a preset does not
# name is off in it.
Strengths = make_dataclass(
    "Strengths", [(name, float, 0.0) for name in STRENGTH_NAMES], bases=(_StrengthsBase,), frozen=True,
    namespace={"__module__": __name__, "__doc__": "Strength coefficients delta of every term, by name "
               "(STRENGTH_NAMES; see ``seamfit.opt.presets``)."})


def positional_weights(mesh) -> np.ndarray:
    """Default u_i: POSITIONAL_WEIGHT_BOUNDARY on panel boundaries, 1 inside."""
    b = np.asarray(mesh.boundary, dtype=bool)
    return np.where(b, POSITIONAL_WEIGHT_BOUNDARY, POSITIONAL_WEIGHT_INTERIOR).astype(float)


def _grid(sdf):
    values = np.ascontiguousarray(sdf.values, dtype=np.float32)
    return values, np.asarray(sdf.origin, dtype=float).reshape(3), float(sdf.spacing)


def sample_sdf(sdf, points) -> tuple[np.ndarray, np.ndarray]:
    """phi and grad phi of a grid SDF (``values`` (nz, ny, nx), ``origin``, ``spacing``)
    with the trilinear interpolant the costs and the simulator use."""
    values, origin, spacing = _grid(sdf)
    return core().sdf_sample_grid(values, origin, spacing, np.asarray(points, dtype=float).reshape(-1, 3))


class CostSet:
    """The fitting costs C, the sum of the COST_TERMS, for a garment sewn from ``mesh``.

    xbar: the base garment (N, 3) m, simulated on the base body. Only the inputs of
    terms with nonzero strength are needed: ``target_sdf`` and ``phibar`` (or
    ``base_sdf`` to compute phibar = phi_base(xbar)) for the distance cost, ``xtilde``
    (the transferred garment) for the positional cost. Zero-strength terms are never
    evaluated; ``evaluations`` counts the evaluations of each term.
    """

    def __init__(self, mesh, xbar, strengths, *, target_sdf=None, phibar=None, base_sdf=None,
                 xtilde=None, positional_weight=None):
        a = mesh_arrays(mesh)
        self.arrays = a
        self.strengths = Strengths.from_any(strengths)
        xbar = np.ascontiguousarray(xbar, dtype=float)
        self.xbar = xbar
        self._native = core().CostSet(a.triangles, a.pbar, xbar)
        s = self.strengths
        self._native.set_strengths({name: getattr(s, name) for name in COST_TERM_NAMES})
        if s.dis != 0:
            if target_sdf is None:
                raise SolveError("the distance cost needs the target body's SDF (target_sdf)")
            if phibar is None:
                if base_sdf is None:
                    raise SolveError("the distance cost needs phibar or the base body's SDF (base_sdf)")
                phibar = sample_sdf(base_sdf, xbar)[0] if hasattr(base_sdf, "values") else base_sdf.sample(xbar)[0]
            self._native.set_target_sdf(*_grid(target_sdf))
            self._native.set_inputs("dis", np.asarray(phibar, dtype=float).reshape(-1))
        if s.pos != 0:
            if xtilde is None:
                raise SolveError("the positional cost needs the transferred garment (xtilde)")
            u = positional_weights(mesh) if positional_weight is None else np.asarray(positional_weight, float)
            self._native.set_inputs("pos", np.column_stack([np.asarray(xtilde, dtype=float), u]))
        self._device_out = Buffers()  # DeviceArray gradients

    _gpu = None  # CudaCostSet mirror when evaluating on the GPU

    def use_device(self, device: str) -> None:
        """Evaluate on "cpu" or on "cuda": a GPU mirror of the terms' constant data
        (the same element functions; strengths are still read from this set)."""
        from ..device import require_device
        if require_device(device, "the cost set", SolveError) == "cuda":
            self._gpu = core().CudaCostSet(self._native)
        else:
            self._gpu = None

    @property
    def device(self) -> str:
        return "cpu" if self._gpu is None else "cuda"

    def evaluate(self, x, p):
        """-> (value, {name: value} per COST_TERM_NAMES, grad_x (N, 3), grad_p (N, 2)). With x and p
        DeviceArrays the gradients are DeviceArrays too (seamfit.device_arrays)."""
        if is_device(x):
            out = self._device_out
            gx, gp = out.get("grad_x", x.shape[0], 3), out.get("grad_p", x.shape[0], 2)
            if self._gpu is not None:
                c, terms = self._gpu.evaluate_device(self._native, x, p, gx, gp)
                return c, terms, gx, gp
            c, terms, hx, hp = self._native.evaluate(host(x), host(p))
            return c, terms, out.put("grad_x", hx), out.put("grad_p", hp)
        x, p = np.asarray(x, dtype=float), np.asarray(p, dtype=float)
        if self._gpu is not None:
            return self._gpu.evaluate(self._native, x, p)
        return self._native.evaluate(x, p)

    @property
    def evaluations(self) -> dict:
        return self._native.evaluations

    @property
    def edges(self) -> np.ndarray:
        return np.asarray(self._native.edges, dtype=np.int64).reshape(-1, 2)

    @property
    def hinges(self) -> np.ndarray:
        return np.asarray(self._native.hinges, dtype=np.int64).reshape(-1, 4)

    @property
    def hinge_weights(self) -> np.ndarray:
        """The smoothness kernel's weights of each hinge's 4 vertices."""
        return np.asarray(self._native.constants("smo"), dtype=float)[:, :4]
