"""The parameters of a computation, as frozen objects validated once (SPEC §1, §2, §6).

- :class:`Physics`: what is simulated — reduced volume ``v``, viscosity ratio ``lam``, shear rate
  ``chi`` and the background linear flow;
- :class:`Discretisation`: how — grid ``n_theta``, shape degree ``N``, rotated-grid size
  ``n_rot``, the layer-potential backend and strategy, threads over latitude rings;
- :class:`SolverTolerances`: the GMRES tolerances of each velocity-tension solve.

Each is a frozen dataclass: ``replace(**changes)`` gives a new, re-validated object; ``to_dict``
and ``from_dict`` round-trip through JSON; ``key`` is a short hash of the content that is the same
in every process and on every machine (a cache key for sweeps).  Every driver takes and stores
these objects, and output files store their dictionaries.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from vesicle.model.flows import FLOWS, LinearFlow
from vesicle.parallel import grid_threads, threads_from_environment
from vesicle.stokes.backends import BACKENDS

__all__ = ["Discretisation", "Physics", "SolverTolerances", "stable_key"]

log = logging.getLogger(__name__)


#: The coarse (grid, degree) pairs already warned about in this process.
_WARNED_COARSE: set[tuple[int, int]] = set()


def stable_key(data: dict, length: int = 12) -> str:
    """A short hex digest of JSON-able ``data``: identical in every process (unlike ``hash``)."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()[:length]


def _number(owner: str, name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ValueError(f"{owner}.{name} must be a number, got {value!r}")
    value = float(value)
    if not np.isfinite(value):
        raise ValueError(f"{owner}.{name} must be finite, got {value}")
    return value


def _integer(owner: str, name: str, value: Any, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        if not (isinstance(value, float) and value.is_integer()):
            raise ValueError(f"{owner}.{name} must be an integer, got {value!r}")
    value = int(value)
    if value < minimum:
        raise ValueError(f"{owner}.{name} must be at least {minimum}, got {value}")
    return value


class _Frozen:
    """``replace``, ``to_dict``, ``from_dict`` and ``key`` for the parameter dataclasses."""

    def replace(self, **changes):
        """A new object with ``changes`` applied (validated again)."""
        unknown = set(changes) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            raise ValueError(f"{type(self).__name__} has no parameter {', '.join(sorted(unknown))}")
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, data: dict):
        """The object of :meth:`to_dict`'s output; unknown keys are refused by name."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(data) - names
        if unknown:
            raise ValueError(
                f"unknown {cls.__name__} parameter(s) {', '.join(sorted(unknown))}; "
                f"expected some of {', '.join(sorted(names))}"
            )
        return cls(**data)

    @property
    def key(self) -> str:
        """Short content hash, stable across processes and machines."""
        return stable_key({"type": type(self).__name__, **self.to_dict()})


@dataclass(frozen=True)
class Physics(_Frozen):
    """The dimensionless physics of SPEC §1.

    Parameters
    ----------
    v : float
        Reduced volume in (0, 1].
    lam : float
        Viscosity ratio ``mu_in / mu_out`` > 0.
    chi : float
        Dimensionless shear rate ``mu a^3 gamma_dot / kappa`` (finite; 0 is rest).
    flow : LinearFlow, str, or 3x3 array
        The background flow ``u_inf = chi G x``: a name of :data:`vesicle.model.flows.FLOWS`
        (``"shear"``, ``"planar-extension"``, ``"rotation"``, ``"none"``), a
        :class:`LinearFlow`, a traceless 3x3 gradient, or ``{"name", "gradient"}``.
    bq : float
        Boussinesq number ``eta_m / (mu_out a)`` of the membrane's surface shear viscosity
        (SPEC §17), finite and >= 0; 0 (the default) is the paper's inviscid membrane.
    """

    v: float = 0.95
    lam: float = 1.0
    chi: float = 1.0
    flow: LinearFlow = field(default_factory=LinearFlow.shear)
    bq: float = 0.0

    def __post_init__(self) -> None:
        v = _number("Physics", "v", self.v)
        if not 0.0 < v <= 1.0:
            raise ValueError(f"reduced volume v must lie in (0, 1], got {v}")
        lam = _number("Physics", "lam", self.lam)
        if lam <= 0.0:
            raise ValueError(f"viscosity ratio lam must be positive, got {lam}")
        chi = _number("Physics", "chi", self.chi)
        bq = _number("Physics", "bq", self.bq)
        if bq < 0.0:
            raise ValueError(f"Boussinesq number bq must be >= 0, got {bq}")
        object.__setattr__(self, "bq", bq)
        object.__setattr__(self, "v", v)
        object.__setattr__(self, "lam", lam)
        object.__setattr__(self, "chi", chi)
        object.__setattr__(self, "flow", _as_flow(self.flow))

    @property
    def driven(self) -> bool:
        """Whether there is a background flow (``chi != 0`` and a non-zero gradient)."""
        return self.chi != 0.0 and not self.flow.is_zero

    def to_dict(self) -> dict:
        return {
            "v": self.v,
            "lam": self.lam,
            "chi": self.chi,
            "flow": {"name": self.flow.name, "gradient": [list(r) for r in self.flow.gradient]},
            "bq": self.bq,
        }

    @property
    def key(self) -> str:
        """Short content hash; an inviscid membrane (``bq = 0``) hashes as before ``bq``
        existed, so the stores of earlier versions keep their keys."""
        data = self.to_dict()
        if data["bq"] == 0.0:
            del data["bq"]
        return stable_key({"type": type(self).__name__, **data})


def _as_flow(flow: Any) -> LinearFlow:
    if isinstance(flow, LinearFlow):
        return flow
    if isinstance(flow, str):
        if flow not in FLOWS:
            raise ValueError(f"unknown flow {flow!r}; choose one of {sorted(FLOWS)}")
        return FLOWS[flow]()
    if isinstance(flow, dict):
        if set(flow) - {"name", "gradient"} or "gradient" not in flow:
            raise ValueError(
                f"a flow dictionary has keys 'name' and 'gradient', got {sorted(flow)}"
            )
        return LinearFlow(tuple(map(tuple, flow["gradient"])), str(flow.get("name", "custom")))
    try:
        gradient = np.asarray(flow, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"cannot read a flow from {flow!r}") from None
    return LinearFlow(tuple(map(tuple, gradient)), "custom")


#: Layer-potential strategies (see :mod:`vesicle.stokes.operators`).
METHODS = ("assembled", "matrix-free")
#: The directions of the steady equations' area and volume multipliers (``Discretisation``).
MULTIPLIERS = ("coefficients", "l2")


@dataclass(frozen=True)
class Discretisation(_Frozen):
    """How the problem is discretised (SPEC §2, §5).

    Parameters
    ----------
    grid : int
        ``n_theta`` Gauss–Legendre rings (``n_phi = 2 n_theta``); SPEC's default 32.
    degree : int
        Degree ``N`` of the radius series (>= 2); SPEC's default 8.  The grid must be much finer
        than ``N`` (the bending force has fourth derivatives and is nonlinear): ``n_theta < 2 N``
        is refused, ``n_theta < 2 N + 4`` warned about.
    n_rot : int or None
        ``theta'`` nodes of the rotated quadrature grid (default: ``grid``).
    backend : str
        Layer-potential assembly kernels: a name of :data:`vesicle.stokes.backends.BACKENDS`
        (``"numba"``, the fused compiled kernels; ``"numpy"``, the reference).
    method : {"assembled", "matrix-free"}
        Dense operators per shape, or rotation of every density.
    workers : int or None
        Threads over latitude rings in assembly (default: :meth:`assembly_threads`:
        ``VESICLE_THREADS``, else 1 on grids of 16 latitudes or fewer, else ``min(2, cpus)``).
    multipliers : {"coefficients", "l2"}
        Along which directions the steady equations' area and volume multipliers act (SPEC
        §8; they absorb the truncated dynamics' small failure to conserve A and V, and vanish
        with the resolution): ``"coefficients"`` (default), the gradients ``dA/da``, ``dV/da``
        in the basis coordinates; ``"l2"``, the L2 gradients of A and V on the unit sphere,
        the directions of the time stepping's drift control
        (:func:`vesicle.dynamics.integrators.restore_area_volume`), so that the steady states
        are the time stepping's fixed points.  The two differ by the multipliers' size
        (docs/reference/steady.md, *Two discretisations of the constraints*).  Time stepping
        has no multipliers and ignores it.
    """

    grid: int = 32
    degree: int = 8
    n_rot: int | None = None
    backend: str = "numba"
    method: str = "assembled"
    workers: int | None = None
    multipliers: str = "coefficients"

    def __post_init__(self) -> None:
        grid = _integer("Discretisation", "grid", self.grid, 4)
        degree = _integer("Discretisation", "degree", self.degree, 2)
        if grid < 2 * degree:
            raise ValueError(
                f"a grid of n_theta = {grid} is too coarse for degree N = {degree}: the bending "
                f"force (fourth derivatives, nonlinear) needs n_theta >= 2 N = {2 * degree}; "
                "SPEC's default is N = 8 on 32 x 64"
            )
        if grid < 2 * degree + 4 and (grid, degree) not in _WARNED_COARSE:
            _WARNED_COARSE.add((grid, degree))  # once per process: objects are made often
            log.warning(
                "grid n_theta = %d is coarse for degree N = %d (below 2 N + 4 = %d): the bending "
                "force aliases, so check what you compute against a finer grid (at N = 8 on "
                "16 x 32 the full report's time-dependent runs were: periods within 7e-6 of "
                "24 x 48); SPEC uses N = 8 on 32 x 64",
                grid,
                degree,
                2 * degree + 4,
            )
        object.__setattr__(self, "grid", grid)
        object.__setattr__(self, "degree", degree)
        if self.n_rot is not None:
            object.__setattr__(self, "n_rot", _integer("Discretisation", "n_rot", self.n_rot, 2))
        if self.workers is not None:
            object.__setattr__(
                self, "workers", _integer("Discretisation", "workers", self.workers, 1)
            )
        if self.backend not in BACKENDS:
            raise ValueError(f"backend must be one of {tuple(BACKENDS)}, got {self.backend!r}")
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        if self.multipliers not in MULTIPLIERS:
            raise ValueError(f"multipliers must be one of {MULTIPLIERS}, got {self.multipliers!r}")

    def to_dict(self) -> dict:
        # the default multipliers are left out, so that the keys, fingerprints and files of
        # every result computed before the option existed stay what they were
        d = super().to_dict()
        if d["multipliers"] == "coefficients":
            del d["multipliers"]
        return d

    def assembly_threads(self) -> int:
        """The threads over latitude rings that assembly uses: ``workers`` if given, else the
        process's ``VESICLE_THREADS`` (:func:`vesicle.parallel.threads_from_environment`), else
        the grid's default (:func:`vesicle.parallel.grid_threads`).  Resolved here, in the
        process that assembles (a Dask worker's own setting applies to the work sent to it)."""
        if self.workers is not None:
            return self.workers
        env = threads_from_environment()
        return env if env is not None else grid_threads(self.grid)

    def operator_options(self) -> dict:
        """Keyword arguments of :class:`vesicle.stokes.LayerPotentials`."""
        return {
            "n_rot": self.n_rot,
            "backend": self.backend,
            "method": self.method,
            "workers": self.assembly_threads(),
        }


@dataclass(frozen=True)
class SolverTolerances(_Frozen):
    """Relative L2 tolerances of the Schur (outer) and ``A_uu`` (inner) GMRES solves (SPEC §6),
    and their iteration limits."""

    schur: float = 1e-3
    inner: float = 1e-4
    max_outer: int = 200
    max_inner: int = 200
    restart: int = 50

    #: Named presets of SPEC §6.
    PRESETS: ClassVar[tuple[str, ...]] = ("time-dependent", "steady")

    def __post_init__(self) -> None:
        for name in ("schur", "inner"):
            value = _number("SolverTolerances", name, getattr(self, name))
            if not 0.0 < value < 1.0:
                raise ValueError(f"tolerance {name} must lie in (0, 1), got {value}")
            object.__setattr__(self, name, value)
        for name in ("max_outer", "max_inner", "restart"):
            object.__setattr__(
                self, name, _integer("SolverTolerances", name, getattr(self, name), 1)
            )

    @classmethod
    def time_dependent(cls) -> SolverTolerances:
        """SPEC §6 preset for time stepping: 1e-3 (Schur), 1e-4 (inner)."""
        return cls(1e-3, 1e-4)

    @classmethod
    def steady(cls) -> SolverTolerances:
        """SPEC §6 preset for steady states and Newton: 1e-6 (Schur), 1e-7 (inner)."""
        return cls(1e-6, 1e-7)

    @classmethod
    def parse(cls, spec: SolverTolerances | str | dict) -> SolverTolerances:
        """A preset name (``"time-dependent"``, ``"steady"``), a dictionary, or the object."""
        if isinstance(spec, cls):
            return spec
        if isinstance(spec, dict):
            return cls.from_dict(spec)
        if spec == "time-dependent":
            return cls.time_dependent()
        if spec == "steady":
            return cls.steady()
        raise ValueError(f"tolerances must be one of {list(cls.PRESETS)} or SolverTolerances")
