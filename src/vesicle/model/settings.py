"""How a steady-state computation is carried out, as frozen objects validated once (SPEC §8–10).

The parameter objects of :mod:`vesicle.model.parameters` say *what* is computed; these say *how*:

- :class:`NewtonSettings`: Newton's tolerance, iteration limit, Jacobian updates, constraint
  order and the velocity solves' tolerances (:func:`vesicle.steady.steady_tank_treading`);
- :class:`StabilitySettings`: the TT branch (orientation), the perturbations analysed (modes) and
  how Jacobians are formed; the default "vorticity-aligned branch ⇒ general modes" is decided here
  and nowhere else;
- :class:`ContinuationSettings`: steps, halvings, the arclength fallback and steps past a fold
  (:func:`vesicle.bifurcation.branch`);
- :class:`CriticalSearch`: the bracketing search for ``lambda_c`` (:func:`vesicle.critical_lambda`);
- :class:`Execution`: where independent evaluations run (workers, a Dask scheduler).

Like the parameter objects each offers ``replace``, ``to_dict``/``from_dict`` (JSON round trip,
unknown keys refused by name) and ``key``.  The drivers take these objects; their former loose
keywords (``tolerance=``, ``modes=``, ``jacobian=``, ...) still work for one release with a
:class:`VesicleDeprecationWarning`.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field
from typing import Any

from vesicle.model.parameters import Discretisation, SolverTolerances, _Frozen, _integer, _number
from vesicle.parallel import executor

__all__ = [
    "CONSTRAINTS",
    "JACOBIANS",
    "MODES",
    "ORIENTATIONS",
    "UPDATES",
    "ContinuationSettings",
    "CriticalSearch",
    "Execution",
    "NewtonSettings",
    "StabilitySettings",
    "VesicleDeprecationWarning",
    "default_modes",
    "legacy_settings",
    "refuse_unknown",
    "warn_loose",
]

#: The TT branches: long axis in the shear plane, or along the vorticity axis (SPEC §13).
ORIENTATIONS = ("flow", "vorticity")
#: The perturbations analysed: x-z symmetric (SPEC §8), or the full basis (2.1).
MODES = ("symmetric", "general")
#: How Jacobians are formed: the solve differentiated, or finite differences (the reference).
JACOBIANS = ("linearised", "differences")
#: Newton's Jacobian updates between fresh ones.
UPDATES = ("broyden", "none")
#: The constraints' order in the Newton matrix.
CONSTRAINTS = ("second-order", "first-order")


class VesicleDeprecationWarning(DeprecationWarning):
    """A call form kept for one release (loose scalars or loose settings keywords)."""


def _choice(owner: str, name: str, value: Any, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise ValueError(f"{owner}.{name} must be one of {allowed}, got {value!r}")
    return value


def _flag(owner: str, name: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"{owner}.{name} must be true or false, got {value!r}")
    return value


def default_modes(orientation: str = "flow", modes: str | None = None) -> str:
    """The perturbations analysed when none are asked for: the x-z symmetric ones on the in-plane
    (``"flow"``) branch, the full basis on the vorticity-aligned one, whose instability breaks
    that symmetry (SPEC §13).  The one place this default is decided."""
    if modes is not None:
        return modes
    return "general" if orientation == "vorticity" else "symmetric"


#: The velocity solves' tolerances inside Newton (SPEC §6's steady preset tightened: the
#: residual is converged to 1e-8, so each solve must be more accurate than that).
NEWTON_SOLVER = SolverTolerances(1e-8, 1e-9)


@dataclass(frozen=True)
class NewtonSettings(_Frozen):
    """Newton–Raphson for a steady state (SPEC §8).

    ``tolerance``: the residual's max-norm at convergence (relative to ``chi`` for the dynamic
    part); ``max_iterations``: ``None`` for 30 with Broyden updates, 12 without
    (:attr:`iterations`); ``updates``: ``"broyden"`` or ``"none"`` (a fresh Jacobian each
    step, the reference); ``chord_contraction``: the largest residual ratio accepted from a step
    on a reused Jacobian; ``constraints``: ``"second-order"`` (the multipliers' curvature in the
    matrix, iterates projected onto the constraints) or ``"first-order"`` (the method before);
    ``preconditioned``: solve the iterates by GMRES preconditioned with the factorised system;
    ``solver``: each velocity solve's tolerances.
    """

    tolerance: float = 1e-8
    max_iterations: int | None = None
    updates: str = "broyden"
    chord_contraction: float = 0.7
    constraints: str = "second-order"
    preconditioned: bool = True
    solver: SolverTolerances = field(default_factory=lambda: NEWTON_SOLVER)

    def __post_init__(self) -> None:
        tolerance = _number("NewtonSettings", "tolerance", self.tolerance)
        if tolerance <= 0:
            raise ValueError(f"NewtonSettings.tolerance must be positive, got {tolerance}")
        object.__setattr__(self, "tolerance", tolerance)
        if self.max_iterations is not None:
            iterations = _integer("NewtonSettings", "max_iterations", self.max_iterations, 1)
            object.__setattr__(self, "max_iterations", iterations)
        _choice("NewtonSettings", "updates", self.updates, UPDATES)
        contraction = _number("NewtonSettings", "chord_contraction", self.chord_contraction)
        if not 0 < contraction < 1:
            raise ValueError(
                f"NewtonSettings.chord_contraction must lie in (0, 1), got {contraction}")
        object.__setattr__(self, "chord_contraction", contraction)
        _choice("NewtonSettings", "constraints", self.constraints, CONSTRAINTS)
        _flag("NewtonSettings", "preconditioned", self.preconditioned)
        object.__setattr__(self, "solver", SolverTolerances.parse(self.solver))

    @property
    def iterations(self) -> int:
        """The iteration limit: ``max_iterations``, else 30 with Broyden updates, 12 without."""
        if self.max_iterations is not None:
            return self.max_iterations
        return 30 if self.updates == "broyden" else 12

    def to_dict(self) -> dict:
        return {**super().to_dict(), "solver": self.solver.to_dict()}


@dataclass(frozen=True)
class StabilitySettings(_Frozen):
    """The branch, the perturbations and the Jacobians of a stability analysis (SPEC §9, §13).

    ``orientation``: ``"flow"`` (the in-plane TT branch) or ``"vorticity"`` (long axis along the
    vorticity); ``modes``: ``"symmetric"`` or ``"general"``, default by orientation
    (:func:`default_modes`: general on the vorticity branch, whose symmetric perturbations miss
    its instability); ``jacobian``: ``"linearised"`` (the solve differentiated) or
    ``"differences"`` (the reference), for Newton's matrix and the stability operator alike.
    """

    orientation: str = "flow"
    modes: str | None = None
    jacobian: str = "linearised"

    def __post_init__(self) -> None:
        _choice("StabilitySettings", "orientation", self.orientation, ORIENTATIONS)
        if self.modes is not None:
            _choice("StabilitySettings", "modes", self.modes, MODES)
        object.__setattr__(self, "modes", default_modes(self.orientation, self.modes))
        _choice("StabilitySettings", "jacobian", self.jacobian, JACOBIANS)


@dataclass(frozen=True)
class ContinuationSettings(_Frozen):
    """Natural continuation with a pseudo-arclength fallback (:func:`vesicle.bifurcation.branch`).

    ``step``: the spacing of ``"LOW:HIGH"`` values; ``locate``: locate special points between
    neighbours to ``xtol`` (relative for ``v`` and ``chi``, absolute for ``lam``);
    ``max_halvings``: halvings of a failed step before natural continuation stops;
    ``arclength``: follow the branch by pseudo-arclength where it stops, to locate the fold;
    ``past_fold``: arclength steps beyond the fold (0: stop there).
    """

    step: float | None = None
    locate: bool = True
    xtol: float = 1e-3
    max_halvings: int = 4
    arclength: bool = True
    past_fold: int = 0

    def __post_init__(self) -> None:
        if self.step is not None:
            step = _number("ContinuationSettings", "step", self.step)
            if step <= 0:
                raise ValueError(f"ContinuationSettings.step must be positive, got {step}")
            object.__setattr__(self, "step", step)
        xtol = _number("ContinuationSettings", "xtol", self.xtol)
        if xtol <= 0:
            raise ValueError(f"ContinuationSettings.xtol must be positive, got {xtol}")
        object.__setattr__(self, "xtol", xtol)
        _flag("ContinuationSettings", "locate", self.locate)
        _flag("ContinuationSettings", "arclength", self.arclength)
        for name in ("max_halvings", "past_fold"):
            value = _integer("ContinuationSettings", name, getattr(self, name), 0)
            object.__setattr__(self, name, value)


@dataclass(frozen=True)
class CriticalSearch(_Frozen):
    """The bracketing search for ``lambda_c`` (:func:`vesicle.critical_lambda`).

    ``lam0``: the first evaluation (default: the leading-order estimate, at least 1); ``step``:
    the relative move of the second; ``factor``: the largest factor of one secant step in
    ``log lam``; ``xtol``: Brent's tolerance on ``lam``; ``coarse``: a first search at a coarse
    resolution (``"auto"``, a :class:`Discretisation`, or ``None``).
    """

    lam0: float | None = None
    step: float = 0.05
    factor: float = 1.5
    xtol: float = 1e-3
    coarse: str | Discretisation | None = "auto"

    def __post_init__(self) -> None:
        if self.lam0 is not None:
            lam0 = _number("CriticalSearch", "lam0", self.lam0)
            if lam0 <= 0:
                raise ValueError(f"CriticalSearch.lam0 must be positive, got {lam0}")
            object.__setattr__(self, "lam0", lam0)
        for name, low in (("step", 0.0), ("factor", 1.0), ("xtol", 0.0)):
            value = _number("CriticalSearch", name, getattr(self, name))
            if value <= low:
                raise ValueError(f"CriticalSearch.{name} must be above {low:g}, got {value}")
            object.__setattr__(self, name, value)
        if isinstance(self.coarse, dict):
            object.__setattr__(self, "coarse", Discretisation.from_dict(self.coarse))
        if not (self.coarse is None or self.coarse == "auto"
                or isinstance(self.coarse, Discretisation)):  # fmt: skip
            raise ValueError(f"CriticalSearch.coarse must be 'auto', None or a Discretisation, "
                             f"got {self.coarse!r}")  # fmt: skip

    def to_dict(self) -> dict:
        data = super().to_dict()
        if isinstance(self.coarse, Discretisation):
            data["coarse"] = self.coarse.to_dict()
        return data


@dataclass(frozen=True)
class Execution(_Frozen):
    """Where independent evaluations run (Jacobian columns, sweep points, report items).

    ``workers``: local one-thread worker processes (``None``: serial for a single computation,
    the cores for a sweep); ``scheduler``: the address of a running Dask scheduler (then
    ``workers`` is not used).  :meth:`executor` makes the ``concurrent.futures`` executor.
    """

    workers: int | None = None
    scheduler: str | None = None

    def __post_init__(self) -> None:
        if self.workers is not None:
            object.__setattr__(self, "workers", _integer("Execution", "workers", self.workers, 1))
        if self.scheduler is not None and not (isinstance(self.scheduler, str) and self.scheduler):
            raise ValueError(f"Execution.scheduler must be an address, got {self.scheduler!r}")

    def executor(self):
        """A context manager giving the executor (``None`` when serial)."""
        return executor(self.workers or 1, self.scheduler)


def legacy_settings(function: str, cls, given, legacy: dict, names: dict[str, str] | None = None):
    """The settings object of ``cls`` for a driver called with its former loose keywords, or
    ``given`` (possibly ``None``) when none of them was passed.

    ``legacy``: the loose keywords (those of ``cls`` are removed from the dictionary); ``names``:
    former keyword -> field where they differ.  A keyword passed as ``None`` counts as not passed
    (the default), except for a field where ``None`` is a value of its own other than the
    default (``CriticalSearch.coarse``: no coarse search).  Loose keywords warn
    (:class:`VesicleDeprecationWarning`) and may not be combined with the object.
    """
    names = names or {}
    fields = {f.name: f for f in dataclasses.fields(cls)}
    used = {names.get(k, k): legacy.pop(k) for k in list(legacy) if names.get(k, k) in fields}
    used = {k: x for k, x in used.items()
            if x is not None or (fields[k].default is not None and "None" in str(fields[k].type))}
    if not used:
        return given
    if given is not None:
        raise TypeError(f"{function}: give {cls.__name__} or the keywords "
                        f"{', '.join(sorted(used))}, not both")  # fmt: skip
    warnings.warn(
        f"{function}'s keywords {', '.join(sorted(used))} are deprecated: pass "
        f"{cls.__name__}({', '.join(f'{k}=...' for k in sorted(used))})",
        VesicleDeprecationWarning, stacklevel=3,
    )  # fmt: skip
    return cls(**used)


def warn_loose(function: str, scalars: dict, stacklevel: int = 3) -> None:
    """The deprecation warning of a driver called with loose physics or resolution scalars
    (``v``, ``lam``, ``chi``, ``degree``, ``grid``) instead of the parameter objects."""
    physics = [k for k in ("v", "lam", "chi") if k in scalars]
    disc = [k for k in ("degree", "grid") if k in scalars]
    what = " and ".join(x for x in (
        f"Physics({', '.join(physics)})" if physics else "",
        f"Discretisation({', '.join(disc)})" if disc else "") if x)  # fmt: skip
    warnings.warn(f"{function} with loose {', '.join(scalars)} is deprecated: pass {what}",
                  VesicleDeprecationWarning, stacklevel=stacklevel + 1)  # fmt: skip


def refuse_unknown(function: str, legacy: dict) -> None:
    """A TypeError naming keywords no settings object took."""
    if legacy:
        raise TypeError(f"{function}() got unexpected keyword argument(s) "
                        f"{', '.join(sorted(legacy))}")  # fmt: skip
