"""Time-dependent simulation of the vesicle shape (SPEC §7, §10, §13).

The radius coefficients evolve by ``dr/dt = Dr/Dt - r_theta Dtheta/Dt - r_phi Dphi/Dt`` (2.18),
with ``Dr/Dt = e_r . u``, ``Dtheta/Dt = e_theta . u / r``, ``Dphi/Dt = e_phi . u / (r sin theta)``
(2.19), ``u`` the membrane velocity of the current shape, and ``dr/dt`` filtered to degree ``N``.

Integrators, all with an embedded error estimate on the coefficients and PI step control:

- ``"ros2"`` (default): the linearly implicit two-stage Rosenbrock-W method ROS2 (Verwer et al.
  1999) with an approximate Jacobian ``-Gamma_l``, the relaxation rates of the unit sphere
  (:func:`vesicle.stokes.spectra.sphere_relaxation_rates` at the current mean tension),
  diagonal in the coefficients.  A W-method keeps its order 2 for any approximate Jacobian; the
  diagonal one takes the bending stiffness (``Gamma_l ~ l^3``) out of the step limit at no
  cost: two velocity solves per step, like an explicit method.  Embedded: the linearly
  implicit Euler step.
- ``"ros34pw2"``: the four-stage Rosenbrock-W method ROS34PW2 of Rang & Angermann (2005), order 3
  for any approximate Jacobian (the same diagonal one), stiffly accurate, with an embedded method
  of order 2: four velocity solves per step, but an error estimate of one order higher than
  ROS2's Euler estimate, so the step grows as ``rtol^(1/3)`` instead of ``rtol^(1/2)``.
- ``"bs3"``: explicit Bogacki–Shampine 3(2), FSAL (three solves per step);
- ``"heun"``: explicit Heun–Euler 2(1) (two solves per step).

The explicit pairs are limited by the stability of the stiff bending modes (the adaptive control
finds that limit, roughly proportional to N^-3).  Steps are shortened to land on save times.

After each accepted step (both logged and stored per saved step): the area and volume are
restored by a minimal-norm normal correction of degree ``<= N`` (the exact dynamics conserves
both; the integrator drifts slowly), and the radius is re-measured from the volume centroid when
that has moved by more than ``recenter_threshold``.
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass, field

import numpy as np

from vesicle.geometry.diagnostics import diagnose, recentered
from vesicle.geometry.surface import Shape, ShapeError
from vesicle.model.kinematics import area_volume_variations, rate_of_change
from vesicle.model.parameters import Discretisation, Physics, SolverTolerances
from vesicle.model.settings import VesicleDeprecationWarning
from vesicle.solve.factorised import FactorisedSystem, preconditioned_solve
from vesicle.solve.solver import FlowResult, SolverError, VelocityTensionSolver, solve_flow
from vesicle.sphere.transforms import resize, transform
from vesicle.stokes.spectra import sphere_relaxation_rates

__all__ = [
    "INTEGRATORS",
    "RUN_DEFAULTS",
    "TABLEAUS",
    "Evaluation",
    "Integrator",
    "RunParameters",
    "StepResult",
    "StepState",
    "initial_shape",
    "post_step",
    "rate_of_change",
    "restore_area_volume",
]

log = logging.getLogger(__name__)

#: Embedded RK pairs: (c, A, b (higher order), b_hat (embedded), order of b, FSAL).
TABLEAUS = {
    "bs3": (
        [0.0, 0.5, 0.75, 1.0],
        [[], [0.5], [0.0, 0.75], [2 / 9, 1 / 3, 4 / 9]],
        [2 / 9, 1 / 3, 4 / 9, 0.0],
        [7 / 24, 1 / 4, 1 / 3, 1 / 8],
        3,
        True,
    ),
    "heun": ([0.0, 1.0], [[], [1.0]], [0.5, 0.5], [1.0, 0.0], 2, False),
}

#: Largest step growth after a run's first step (5 after every other).
START_UP_GROWTH = 100.0

#: ROS2's diagonal coefficient; ``1 + 1/sqrt(2)`` makes it L-stable for an exact Jacobian.
ROS2_GAMMA = 1.0 + 1.0 / np.sqrt(2.0)

#: Rosenbrock-W tableaus in the form of Hairer & Wanner (IV.7.4), with ``W = I + h gamma Gamma``:
#: ``W k_i = h F(y + sum_j alpha_ij k_j) - h Gamma sum_j gamma_ij k_j``, ``y+ = y + sum b_i k_i``,
#: error ``sum (b_i - b_hat_i) k_i``.  Entries: (gamma, alpha, gamma_ij (strictly lower), b,
#: b_hat, order of the error estimate's local error).  ROS34PW2: Rang & Angermann, BIT 45 (2005)
#: 761-787, Table 4.2; its orders (3 and 2 for an arbitrary W) are checked numerically in
#: tests/dynamics/test_simulation.py.
ROSW_TABLEAUS = {
    "ros34pw2": (
        4.3586652150845900e-01,
        [[], [8.7173304301691801e-01], [8.4457060015369423e-01, -1.1299064236484185e-01],
         [0.0, 0.0, 1.0]],
        [[], [-8.7173304301691801e-01], [-9.0338057013044082e-01, 5.4180672388095326e-02],
         [2.4212380706095346e-01, -1.2232505839045147e00, 5.4526025533510214e-01]],
        [2.4212380706095346e-01, -1.2232505839045147e00, 1.5452602553351020e00,
         4.3586652150845900e-01],
        [3.7810903145819369e-01, -9.6042292212423178e-02, 0.5, 2.1793326075422950e-01],
        3,
    ),
}  # fmt: skip

#: The registry of integrators: name -> family (the :class:`Integrator` methods
#: ``_setup_<family>`` and ``_step_<family>`` that realise it): ROS2, the Rosenbrock-W methods
#: of ``ROSW_TABLEAUS`` and the explicit pairs of ``TABLEAUS``.  A new tableau is one entry of
#: its table; a new family one pair of methods and its names here.
SCHEMES: dict[str, str] = {"ros2": "ros2", **dict.fromkeys(ROSW_TABLEAUS, "rosw"),
                           **dict.fromkeys(TABLEAUS, "rk")}  # fmt: skip

#: Integrators by name (the CLI's choices): the linearly implicit W-methods (ROS2 and
#: ``ROSW_TABLEAUS``) and the explicit pairs of ``TABLEAUS``.
INTEGRATORS = tuple(SCHEMES)


#: The run's own settings (everything but physics, discretisation and solver tolerances), with
#: their defaults.
#: The defaults make ``vesicle run`` alone a physical result in about 1 min 10 s on 2 cores: the
#: default point (v = 0.95, lam = 1, chi = 1, N = 8 on 32 x 64) from the spheroid settles on
#: tank-treading by t = 2.85 (psi = 0.5648), where the run stops (``steady_tol``).  ROS34PW2
#: at rtol 1e-3 reaches psi within 1e-4 of a tight reference with a third to a tenth of ROS2's
#: solves (docs/notes/dynamics-measurements.md, *Equal accuracy*); ``t_end`` is a cap for runs
#: that never settle.
RUN_DEFAULTS = {
    "t_end": 10.0,
    "save_every": 0.1,
    "init": "spheroid",
    "tilt": 0.0,  # degrees, about the shorter in-plane principal axis (SPEC §13)
    "perturb": 0.0,
    "seed": 0,
    "integrator": "ros34pw2",
    "rtol": 1e-3,  # local error per step, relative to the mean radius
    "dt0": 1e-3,
    "dt_min": 1e-7,
    "dt_max": 0.1,
    "drift_control": True,
    "drift_tol": 1e-5,  # relative area/volume drift that triggers a correction
    "recenter_threshold": 1e-4,
    "steady_tol": 1e-3,  # stop when max |dr/dt| falls below this (0: never)
    "periods": 0,  # stop after this many settled psi periods (0: never; analysis.settled_periods)
    # stop once the long axis's orbit out of the plane (precession, figure-8) has run this many of
    # its periods twice over, alike (0: never; diagnostics.settled_orbit; SPEC §13)
    "orbits": 0,
    "split_stress": False,  # also store S^B and S^V at saved steps (two more solves each)
    "save_fields": True,  # store the tension and the membrane velocity on the grid
    "checkpoint_every": 60.0,  # wall seconds between checkpoints
    # a viscous membrane's solves (Bq > 0): GMRES preconditioned by a kept factorised system
    # ("factorised", refreshed when it needs more than REFRESH_ITERATIONS iterations), or the
    # nested GMRES of every other run ("nested", the reference; far slower with Bq: its inner
    # operator is far from normal)
    "viscous_solve": "factorised",
}

#: The run settings that only decide when a run stops: a run to an earlier stop is the beginning
#: of the same trajectory, so a resumed run may change them.
STOP_KEYS = ("t_end", "periods", "orbits", "steady_tol")

#: The ways of a viscous membrane's solves in time stepping (``RunParameters.viscous_solve``).
VISCOUS_SOLVES = ("factorised", "nested")

#: GMRES iterations of a preconditioned solve beyond which the kept factorised system is
#: refreshed at the current shape and the solve repeated.
REFRESH_ITERATIONS = 8

_PHYSICS_KEYS = ("v", "lam", "chi", "flow", "bq")
_DISCRETISATION_KEYS = ("grid", "degree", "n_rot", "backend", "method", "workers")


@dataclass(frozen=True, init=False)
class RunParameters:
    """Everything that defines a time-dependent run (stored in its output file).

    Composed of a :class:`~vesicle.model.parameters.Physics`, a
    :class:`~vesicle.model.parameters.Discretisation`, the :class:`SolverTolerances` of each solve
    (default: SPEC §6's time-dependent preset) and the run's own settings
    (:data:`RUN_DEFAULTS`), e.g. ``RunParameters(Physics(v=0.95, lam=8, chi=10),
    Discretisation(), t_end=5)``; ``tolerances`` may be a preset name; ``v``, ``lam``, ``chi``,
    ``flow``, ``grid`` and ``degree`` read through, and :meth:`replace` takes them flat.  The
    former flat constructor (``RunParameters(v=0.95, lam=8, chi=10, t_end=5)``) works for one
    release, with a :class:`~vesicle.model.settings.VesicleDeprecationWarning`.
    """

    physics: Physics
    discretisation: Discretisation
    solver: SolverTolerances
    t_end: float
    save_every: float
    init: str
    tilt: float
    perturb: float
    seed: int
    integrator: str
    rtol: float
    dt0: float
    dt_min: float
    dt_max: float
    drift_control: bool
    drift_tol: float
    recenter_threshold: float
    steady_tol: float
    periods: int
    orbits: int
    split_stress: bool
    save_fields: bool
    checkpoint_every: float
    viscous_solve: str

    def __init__(
        self,
        physics: Physics | None = None,
        discretisation: Discretisation | None = None,
        solver: SolverTolerances | str | dict | None = None,
        **options,
    ):
        flat_p = {k: options.pop(k) for k in _PHYSICS_KEYS if k in options}
        flat_d = {k: options.pop(k) for k in _DISCRETISATION_KEYS if k in options}
        if "tolerances" in options:
            if solver is not None:
                raise ValueError("give solver or tolerances, not both")
            solver = options.pop("tolerances")
        unknown = set(options) - set(RUN_DEFAULTS)
        if unknown:
            raise ValueError(f"unknown run parameter(s) {', '.join(sorted(unknown))}")
        physics = _compose(Physics, physics, flat_p, "physics")
        discretisation = _compose(Discretisation, discretisation, flat_d, "discretisation")
        if flat_p or flat_d:
            warnings.warn(f"RunParameters with flat {', '.join([*flat_p, *flat_d])} is deprecated: "
                          "pass Physics and Discretisation objects (or use replace(...))",
                          VesicleDeprecationWarning, stacklevel=2)  # fmt: skip
        solver = SolverTolerances.parse(solver if solver is not None else "time-dependent")
        object.__setattr__(self, "physics", physics)
        object.__setattr__(self, "discretisation", discretisation)
        object.__setattr__(self, "solver", solver)
        for name, default in RUN_DEFAULTS.items():
            object.__setattr__(self, name, options.get(name, default))
        self._validate()

    def _validate(self) -> None:
        for name, default in RUN_DEFAULTS.items():
            value = getattr(self, name)
            if isinstance(default, bool):
                if not isinstance(value, bool | np.bool_):
                    raise ValueError(f"{name} must be true or false, got {value!r}")
            elif isinstance(default, int | float) and (
                isinstance(value, bool)
                or not isinstance(value, int | float | np.number)
                or not np.isfinite(value)
            ):
                raise ValueError(f"{name} must be a finite number, got {value!r}")
        for name in ("t_end", "save_every", "rtol", "dt0", "dt_min", "dt_max"):
            if getattr(self, name) <= 0.0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        for name in ("perturb", "steady_tol", "drift_tol", "recenter_threshold"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"{name} must not be negative, got {getattr(self, name)}")
        if not 0.0 < self.rtol < 1.0:  # an error per step as large as the vesicle is no control
            raise ValueError(f"rtol must lie in (0, 1) (local error per step relative to the "
                             f"mean radius), got {self.rtol}")  # fmt: skip
        if self.periods < 0 or self.periods == 1:
            raise ValueError(f"periods must be 0 (never stop on periods) or at least 2 (the "
                             f"last ones are compared), got {self.periods}")  # fmt: skip
        if self.orbits < 0 or self.orbits == 1:
            raise ValueError(f"orbits must be 0 (never stop on the orbit) or at least 2 (two "
                             f"windows of that many periods are compared), got "
                             f"{self.orbits}")  # fmt: skip
        if self.perturb >= 1.0:  # the largest radius change as large as the mean radius: the
            # radius goes through zero somewhere, which no radial shape can hold (SPEC §2)
            raise ValueError(f"perturb is the largest radius change relative to the mean radius "
                             f"and must be below 1, got {self.perturb}")  # fmt: skip
        if self.seed < 0:
            raise ValueError(f"seed must not be negative, got {self.seed}")
        if self.checkpoint_every <= 0.0:
            raise ValueError(f"checkpoint_every must be positive, got {self.checkpoint_every}")
        if self.dt_min > self.dt_max:
            raise ValueError("dt_min must not exceed dt_max")
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {INTEGRATORS}, got {self.integrator!r}")
        if self.viscous_solve not in VISCOUS_SOLVES:
            raise ValueError(f"viscous_solve must be one of {VISCOUS_SOLVES}, got "
                             f"{self.viscous_solve!r}")  # fmt: skip

    # the physics and discretisation, read through
    v = property(lambda self: self.physics.v)
    lam = property(lambda self: self.physics.lam)
    chi = property(lambda self: self.physics.chi)
    flow = property(lambda self: self.physics.flow)
    bq = property(lambda self: self.physics.bq)
    grid = property(lambda self: self.discretisation.grid)
    degree = property(lambda self: self.discretisation.degree)

    def replace(self, **changes) -> RunParameters:
        """A new object; ``changes`` may name run settings or flat physics/discretisation keys."""
        p = {k: changes.pop(k) for k in _PHYSICS_KEYS if k in changes}
        d = {k: changes.pop(k) for k in _DISCRETISATION_KEYS if k in changes}
        fields = {
            "physics": self.physics.replace(**p),
            "discretisation": self.discretisation.replace(**d),
            "solver": self.solver,
            **{name: getattr(self, name) for name in RUN_DEFAULTS},
        }
        return RunParameters(**{**fields, **changes})  # objects: no flat keys left

    def to_dict(self) -> dict:
        return {
            "physics": self.physics.to_dict(),
            "discretisation": self.discretisation.to_dict(),
            "solver": self.solver.to_dict(),
            **{name: getattr(self, name) for name in RUN_DEFAULTS},
        }

    @classmethod
    def from_dict(cls, data: dict) -> RunParameters:
        """From :meth:`to_dict`'s output, or from the flat parameters of files written before
        the parameter objects (``v, lam, chi, flow, grid, degree, tolerances, ...``)."""
        data = dict(data)
        data.pop("flow_gradient", None)  # the flat format's record of the flow
        if "physics" in data:
            data["physics"] = Physics.from_dict(data["physics"])
        if "discretisation" in data:
            data["discretisation"] = Discretisation.from_dict(data["discretisation"])
        if isinstance(data.get("solver"), dict):
            data["solver"] = SolverTolerances.from_dict(data["solver"])
        # files of the flat format: their keys made into the objects here (stored files keep
        # working without the deprecated flat constructor)
        flat_p = {k: data.pop(k) for k in _PHYSICS_KEYS if k in data}
        flat_d = {k: data.pop(k) for k in _DISCRETISATION_KEYS if k in data}
        if flat_p:
            data["physics"] = _compose(Physics, data.get("physics"), flat_p, "physics")
        if flat_d:
            data["discretisation"] = _compose(Discretisation, data.get("discretisation"),
                                              flat_d, "discretisation")  # fmt: skip
        return cls(**data)


def _compose(cls, obj, flat: dict, name: str):
    if obj is None:
        return cls(**flat)
    if not isinstance(obj, cls):
        raise TypeError(f"{name} must be a {cls.__name__}, got {type(obj).__name__}")
    if flat:
        raise ValueError(f"give {name} as a {cls.__name__} or as keywords, not both")
    return obj


@dataclass(frozen=True, eq=False)
class Evaluation:
    """The right-hand side at one shape: the solve and the filtered ``dr/dt`` coefficients."""

    shape: Shape
    rate: np.ndarray  # (N+1, N+1) complex
    flow: FlowResult


@dataclass
class StepState:
    """The integrator's state between steps: all that a bit-identical restart needs.

    ``sigma_in`` is the tension warm start with which the current state was (and on restart
    will again be) evaluated, so the restarted run repeats the same GMRES iterations.
    """

    t: float
    coefficients: np.ndarray
    dt: float
    sigma_in: np.ndarray | None = None
    steps: int = 0
    rejected: int = 0
    solves: int = 0  # velocity-tension solves so far (the cost)
    next_save: float = 0.0
    area0: float = 4.0 * np.pi
    volume0: float = 0.0
    previous_error: float = 1.0  # the step-size controller's memory
    last_dt: float = 0.0  # the step that reached ``t`` (recorded with the state it reached)
    stopped: str = ""  # why the run ended: "t_end", "steady" (steady_tol), "periods", "orbit"
    # (orbits); "" running
    corrections: dict = field(
        default_factory=lambda: {"area": 0.0, "volume": 0.0, "recentered": 0, "evaluations": 0}
    )
    #: a viscous membrane's preconditioner: the coefficients of the shape whose system the
    #: integrator keeps factorised (None: none kept)
    anchor: np.ndarray | None = None

    def to_checkpoint(self) -> dict:
        ck = {
            "t": self.t,
            "coefficients": self.coefficients,
            "dt": self.dt,
            "steps": self.steps,
            "rejected": self.rejected,
            "solves": self.solves,
            "next_save": self.next_save,
            "area0": self.area0,
            "volume0": self.volume0,
            "corrections": self.corrections,
            "previous_error": self.previous_error,
            "last_dt": self.last_dt,
            "stopped": self.stopped,
        }
        if self.sigma_in is not None:
            ck["sigma_in"] = self.sigma_in
        if self.anchor is not None:
            ck["preconditioner_shape"] = self.anchor
        return ck

    @classmethod
    def from_checkpoint(cls, ck: dict) -> StepState:
        return cls(
            t=float(ck["t"]),
            coefficients=np.asarray(ck["coefficients"]),
            dt=float(ck["dt"]),
            sigma_in=ck.get("sigma_in"),
            steps=int(ck["steps"]),
            rejected=int(ck["rejected"]),
            solves=int(ck.get("solves", 0)),
            next_save=float(ck["next_save"]),
            area0=float(ck["area0"]),
            volume0=float(ck["volume0"]),
            corrections=dict(ck["corrections"]),
            previous_error=float(ck.get("previous_error", 1.0)),
            last_dt=float(ck.get("last_dt", 0.0)),
            stopped=str(ck.get("stopped", "")),
            anchor=(np.asarray(ck["preconditioner_shape"]) if "preconditioner_shape" in ck
                    else None),
        )


class Integrator:
    """Adaptive stepping of the radius coefficients (see the module docstring)."""

    def __init__(self, params: RunParameters):
        self.params = params
        family = SCHEMES[params.integrator]
        getattr(self, f"_setup_{family}")(params.integrator)
        self._step = getattr(self, f"_step_{family}")
        self.tolerances = params.solver
        self.previous_error = 1.0  # of the last accepted step, for the PI controller
        self.start_up = False  # set for a run's first step (see _next_dt)
        self.solves = 0  # velocity-tension solves made by :meth:`evaluate`
        # a viscous membrane's solves: preconditioned by the factorised system of the shape
        # ``anchor`` (its coefficients: what a checkpoint keeps, so that a resumed run
        # factorises the same shape and repeats the same iterations)
        self.preconditioned = params.physics.bq > 0 and params.viscous_solve == "factorised"
        self.anchor: np.ndarray | None = None
        self._system = None
        self.factorisations = 0

    def restore_anchor(self, anchor: np.ndarray | None) -> None:
        """Factorise the shape of a checkpoint's ``anchor`` (a resumed run), or forget it."""
        self._system, self.anchor = None, None
        if anchor is not None and self.preconditioned:
            self._factorise(np.asarray(anchor))

    def _factorise(self, coefficients: np.ndarray) -> None:
        shape = Shape(coefficients, self.params.grid)
        solver = VelocityTensionSolver(shape, self.params.physics, self.tolerances, None, None,
                                       self.params.discretisation)  # fmt: skip
        self._system = FactorisedSystem(solver)
        self.anchor = np.array(coefficients, copy=True)
        self.factorisations += 1
        log.debug("factorised the system of a viscous membrane (%d so far)", self.factorisations)

    def _preconditioned_flow(self, shape: Shape, sigma0) -> FlowResult:
        """The solve of a viscous membrane: GMRES preconditioned by the kept factorised system
        (its shape refreshed to this one when GMRES needs more than
        :data:`REFRESH_ITERATIONS`), to the tighter of the two solve tolerances on the whole
        system's residual.  An exact sphere (not factorisable) takes the nested solve."""
        solver = VelocityTensionSolver(shape, self.params.physics, self.tolerances, None, None,
                                       self.params.discretisation)  # fmt: skip
        if solver.is_sphere:
            return solve_flow(shape, self.params.physics, tolerances=self.tolerances,
                              discretisation=self.params.discretisation, sigma0=sigma0)  # fmt: skip
        rtol = min(self.tolerances.schur, self.tolerances.inner)
        if self._system is not None:
            flow = preconditioned_solve(solver, self._system, rtol, REFRESH_ITERATIONS)
            if flow.converged:
                return flow
        self._factorise(shape.coefficients)
        flow = preconditioned_solve(solver, self._system, rtol, self.tolerances.max_outer)
        if not flow.converged:
            raise SolverError(f"the preconditioned solve of a viscous membrane missed rtol "
                              f"{rtol:.0e} at its own shape's factorisation", flow)  # fmt: skip
        return flow

    def _next_dt(self, dt: float, err: float) -> float:
        """PI step-size control (Gustafsson): damps the accept/reject cycling that plain
        control shows at the stability limit of stiff (bending) modes.  After a rejection the
        step shrinks by the elementary rule alone."""
        k = self.order
        err = max(err, 1e-10)
        if err > 1.0:
            factor = max(0.2, 0.9 * err ** (-1.0 / k))
        elif self.start_up:  # the first step of a run (dt0, usually far too small): the
            # elementary rule, growth up to START_UP_GROWTH instead of 5 (saves the 3-4 steps
            # of growing by 5 from dt0 = 1e-3 to an accuracy-limited step of ~0.1)
            factor = min(START_UP_GROWTH, 0.9 * err ** (-1.0 / k))
            self.previous_error = err
        else:
            factor = 0.9 * err ** (-0.7 / k) * self.previous_error ** (0.4 / k)
            factor = min(5.0, max(0.2, factor))
            self.previous_error = err
        return float(np.clip(dt * factor, self.params.dt_min, self.params.dt_max))

    def evaluate(self, coefficients: np.ndarray, sigma0: np.ndarray | None) -> Evaluation:
        shape = Shape(coefficients, self.params.grid)
        self.solves += 1
        if self.preconditioned:
            flow = self._preconditioned_flow(shape, sigma0)
            return Evaluation(shape, rate_of_change(shape, flow.u, self.params.degree), flow)
        flow = solve_flow(
            shape,
            self.params.physics,
            tolerances=self.tolerances,
            discretisation=self.params.discretisation,
            sigma0=sigma0,
        )
        return Evaluation(shape, rate_of_change(shape, flow.u, self.params.degree), flow)

    def _error_norm(self, y: np.ndarray, err: np.ndarray) -> float:
        scale = abs(y[0, 0]) / np.sqrt(2.0)  # mean radius
        return float(np.max(np.abs(err)) / (self.params.rtol * scale))

    def step(self, y: np.ndarray, dt: float, first: Evaluation) -> StepResult:
        """Try one step of size ``dt`` from ``y``, where ``first`` is the evaluation at ``y``."""
        return self._step(y, dt, first)

    # The families of SCHEMES: each a ``_setup_<family>(name)`` (the tableau's arrays and the
    # order) and a ``_step_<family>(y, dt, first)``.
    def _setup_ros2(self, name: str) -> None:
        self.order, self.fsal = 2, False

    def _setup_rosw(self, name: str) -> None:
        self.gamma, self.alpha, self.gammas, b, b_hat, order = ROSW_TABLEAUS[name]
        self.b, self.e = np.array(b), np.array(b) - np.array(b_hat)
        self.order, self.fsal = order, False

    def _setup_rk(self, name: str) -> None:
        c, A, b, b_hat, order, fsal = TABLEAUS[name]
        self.c, self.A, self.b = c, A, np.array(b)
        self.e = np.array(b) - np.array(b_hat)
        self.order, self.fsal = order, fsal

    def stiffness(self, first: Evaluation) -> np.ndarray:
        """The approximate Jacobian's rates ``Gamma_l >= 0`` at the evaluation ``first``: the unit
        sphere's at the shape's mean tension, scaled to its mean radius ``a`` (``Gamma`` scales
        as ``a^-3``, the tension as ``a^-2``).  Negative rates (growing modes of a compressed
        membrane) are not stiff and are left to the explicit part."""
        shape = first.shape
        a = np.sqrt(shape.area / (4.0 * np.pi))
        sigma = float(shape.integrate(first.flow.sigma)) / shape.area
        rates = sphere_relaxation_rates(self.params.degree, self.params.lam, sigma * a * a,
                                        self.params.bq / a)  # fmt: skip
        return np.maximum(rates, 0.0) / a**3

    def _step_ros2(self, y: np.ndarray, dt: float, first: Evaluation) -> StepResult:
        """ROS2: ``W k1 = F(y)``, ``W k2 = F(y + dt k1) - 2 k1``, ``y+ = y + dt (3 k1 + k2)/2``,
        ``W = I + gamma dt Gamma`` (diagonal per degree); error ``dt (k1 + k2)/2``."""
        inverse_w = 1.0 / (1.0 + ROS2_GAMMA * dt * self.stiffness(first))[:, None]
        k1 = inverse_w * first.rate
        sigma = first.flow.sigma
        try:
            second = self.evaluate(y + dt * k1, sigma)
        except ShapeError:  # the stage left the representable set: a too-large step
            return StepResult(False, np.inf, y, dt * 0.25, None, sigma)
        k2 = inverse_w * (second.rate - 2.0 * k1)
        y_new = y + dt * (1.5 * k1 + 0.5 * k2)
        err_norm = self._error_norm(y, 0.5 * dt * (k1 + k2))
        dt_next = self._next_dt(dt, err_norm)
        return StepResult(err_norm <= 1.0, err_norm, y_new, dt_next, None, second.flow.sigma)

    def _step_rosw(self, y: np.ndarray, dt: float, first: Evaluation) -> StepResult:
        """One step of a tableau of ``ROSW_TABLEAUS`` (form in its comment); the stiffness
        ``Gamma`` of ``first`` serves every stage (a W-method's order holds for any)."""
        gamma_l = self.stiffness(first)[:, None]
        inverse_w = 1.0 / (1.0 + self.gamma * dt * gamma_l)
        k = [inverse_w * (dt * first.rate)]
        sigma = first.flow.sigma
        for i in range(1, len(self.b)):
            yi = y + sum(a * kj for a, kj in zip(self.alpha[i], k, strict=False) if a != 0.0)
            try:
                stage = self.evaluate(yi, sigma)
            except ShapeError:  # the stage left the representable set: a too-large step
                return StepResult(False, np.inf, y, dt * 0.25, None, first.flow.sigma)
            sigma = stage.flow.sigma
            coupling = sum(g * kj for g, kj in zip(self.gammas[i], k, strict=False))
            k.append(inverse_w * (dt * stage.rate - dt * gamma_l * coupling))
        y_new = y + sum(bj * kj for bj, kj in zip(self.b, k, strict=False))
        err_norm = self._error_norm(y, sum(ej * kj for ej, kj in zip(self.e, k, strict=False)))
        dt_next = self._next_dt(dt, err_norm)
        return StepResult(err_norm <= 1.0, err_norm, y_new, dt_next, None, sigma)

    def _step_rk(self, y: np.ndarray, dt: float, first: Evaluation) -> StepResult:
        k = [first.rate]
        sigma = first.flow.sigma
        last, sigma_last = None, None
        for i in range(1, len(self.c)):
            yi = y + dt * sum(a * kj for a, kj in zip(self.A[i], k, strict=False))
            try:
                sigma_last = sigma
                last = self.evaluate(yi, sigma)
            except ShapeError:  # the stage left the representable set: a too-large step
                return StepResult(False, np.inf, y, dt * 0.25, None, sigma)
            sigma = last.flow.sigma
            k.append(last.rate)
        y_new = y + dt * sum(bj * kj for bj, kj in zip(self.b, k, strict=False))
        err = dt * sum(ej * kj for ej, kj in zip(self.e, k, strict=False))
        err_norm = self._error_norm(y, err)
        dt_next = self._next_dt(dt, err_norm)
        if self.fsal:
            return StepResult(err_norm <= 1.0, err_norm, y_new, dt_next, last, sigma_last)
        return StepResult(err_norm <= 1.0, err_norm, y_new, dt_next, None, sigma)


@dataclass(frozen=True, eq=False)
class StepResult:
    """Outcome of :meth:`Integrator.step`.

    ``final`` is the evaluation at ``y_new`` when the pair is FSAL (else ``None``), made with the
    warm start ``sigma``; otherwise ``sigma`` is the warm start for evaluating ``y_new``.
    """

    accepted: bool
    error: float
    y_new: np.ndarray
    dt_next: float
    final: Evaluation | None
    sigma: np.ndarray | None


#: Relative area/volume error that :func:`restore_area_volume` accepts after its iterations.
RESTORE_TOLERANCE = 1e-12


def restore_area_volume(
    shape: Shape, area: float, volume: float, degree: int, iterations: int = 8
) -> tuple[Shape, float, float]:
    """Minimal-norm normal correction of degree ``<= degree`` restoring ``area`` and ``volume``.

    ``delta r = alpha g_A + beta g_V`` with the L2 gradients ``g_A = -2 H (n . e_r) J``,
    ``g_V = (n . e_r) J`` on the unit sphere, projected to degree ``degree``.  Returns the shape
    and the relative area and volume errors it removed.  Newton on the two constraints,
    until they hold to 1e-14 (two steps from the usual 1e-5 drift, five from 1 %), at most
    ``iterations`` steps; :class:`ShapeError` if they then still miss by more than 1e-12.
    """
    da, dv = 1.0 - shape.area / area, 1.0 - shape.volume / volume
    T = transform(shape.grid.n_theta, degree)
    for k in range(iterations + 1):
        err = np.array([area - shape.area, volume - shape.volume])
        if np.all(np.abs(err) <= 1e-14 * np.array([area, volume])):
            break
        if k == iterations:  # Newton on two constraints: quadratic, so this means trouble
            if np.all(np.abs(err) <= RESTORE_TOLERANCE * np.array([area, volume])):
                break
            raise ShapeError(
                f"drift control did not restore area and volume in {iterations} Newton steps "
                f"(relative errors {err[0] / area:.1e}, {err[1] / volume:.1e})"
            )
        J = shape.area_element
        densities = [var * J for var in area_volume_variations(shape)]
        grads = [T.analysis(g) for g in densities]
        fields = [T.synthesis(g) for g in grads]
        w = shape.grid.weights
        M = np.array([[np.sum(w * gi * fj) for fj in fields] for gi in densities])
        alpha, beta = np.linalg.solve(M, err)
        c = resize(shape.coefficients, degree) + alpha * grads[0] + beta * grads[1]
        shape = Shape(c, shape.grid)
    return shape, da, dv


def initial_shape(params: RunParameters, source: Shape | None = None) -> Shape:
    """The start shape: a spheroid of ``v`` (area 4 pi, long axis x) or ``source``, then the
    optional tilt about the shorter in-plane principal axis and random perturbation."""
    shape = source if source is not None else Shape.spheroid(params.v, params.grid, params.degree)
    shape = Shape(resize(shape.coefficients, params.degree), params.grid)
    if params.tilt:
        d = diagnose(shape)
        in_plane = np.argsort(np.abs(d.axes[:, 1]))[:2]
        short = d.axes[min(in_plane, key=lambda k: d.lengths[k])]
        shape = shape.rotated(_axis_rotation(short, np.radians(params.tilt)))
    if params.perturb:
        shape = shape.perturbed(params.perturb, seed=params.seed, degree=params.degree)
        shape = Shape(resize(shape.coefficients, params.degree), params.grid)
    return shape


def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation by ``angle`` about the unit ``axis`` (Rodrigues)."""
    a = axis / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def post_step(shape: Shape, state: StepState, params: RunParameters) -> tuple[Shape, bool]:
    """Drift control and re-centring after an accepted step, when needed (recorded in ``state``).

    The area and volume are restored once either has drifted by more than ``drift_tol``
    (relative); the radius is re-measured from the volume centroid once that has moved by more
    than ``recenter_threshold``.  Returns the shape and whether it changed.
    """
    changed = False
    centre = shape.centroid
    if np.linalg.norm(centre) > params.recenter_threshold:
        # first: the re-measured radius, projected to degree N, moves the area and volume slightly
        shape = Shape(resize(recentered(shape).coefficients, params.degree), params.grid)
        state.corrections["recentered"] += 1
        changed = True
        log.info(
            "t=%.5f re-centred on the volume centroid (moved by %.2e)",
            state.t,
            np.linalg.norm(centre),
        )
    if params.drift_control:
        da = abs(1.0 - shape.area / state.area0)
        dv = abs(1.0 - shape.volume / state.volume0)
        if max(da, dv) > params.drift_tol:
            shape, da, dv = restore_area_volume(shape, state.area0, state.volume0, params.degree)
            state.corrections["area"] += abs(da)
            state.corrections["volume"] += abs(dv)
            changed = True
            log.debug("t=%.5f drift control removed dA/A=%.2e dV/V=%.2e", state.t, da, dv)
    return shape, changed
