"""What a new user trips over (issue 38): bad inputs to every command and config file.

Each case is one command line.  A *refused* case must end before any work with a non-zero exit
code and one ``Error:`` line from click on stderr that names the option or key (``match``), no
traceback, and nothing written into the folder it runs in.  A *documented* case is accepted:
it reaches the start of the work (stubbed out here), and its comment says where the behaviour
is documented.

The work is stubbed by :func:`stub_work`: building layer potentials, a velocity solve, time
stepping, a Dask LocalCluster and the report's items raise :class:`WorkStarted`, so that a case
accepted by mistake fails at once ("started work") instead of computing, and no case costs more
than its parsing.  Every case runs in-process (click's ``CliRunner``, ``catch_exceptions=False``
so that a traceback surfaces as the test's error) under a 60 s alarm.

Where the expected behaviour comes from: the option's ``--help`` text, the parameter objects'
docstrings (``vesicle.Physics``, ``vesicle.Discretisation``,
``vesicle.dynamics.integrators.RUN_DEFAULTS``),
README.md ("An existing output file is not replaced without --overwrite; a missing or read-only
output folder is refused before any work") and docs/howto/sweeps.md ("Everything is checked before
any work").
"""

from __future__ import annotations

import re
import shlex
import signal
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

import vesicle as vs
from vesicle.cli import main

SECONDS = 60  # per case: parsing and checks only


class WorkStarted(Exception):
    """A case got past the checks to real work (stubbed out)."""


# ------------------------------------------------------------------ fixtures
def make_inputs(folder: Path) -> dict[str, str]:
    """Files the cases read, in ``folder``: a tiny run file and steady-state file (N = 2 on
    8 x 16, a second each), a sweep store without points, and files of the wrong kind."""
    from vesicle.dynamics.integrators import RunParameters
    from vesicle.dynamics.simulation import simulate
    from vesicle.model.parameters import Discretisation, Physics
    from vesicle.steady.files import write_steady
    from vesicle.steady.newton import steady_tank_treading
    from vesicle.workflows.sweep import SweepStore

    simulate(
        RunParameters(
            vs.Physics(), vs.Discretisation(grid=8, degree=2), t_end=0.01, save_every=0.005
        ),
        out=folder / "run.h5",
    )
    write_steady(folder / "tt.h5", steady_tank_treading(Physics(), Discretisation(8, 2)), None)
    SweepStore(folder / "store.h5", "fingerprint", "", "tt").write()
    (folder / "text.h5").write_text("not HDF5\n")
    (folder / "empty.h5").write_bytes(b"")
    (folder / "text.json").write_text('{"not": "a branch or neutral curve"}\n')
    (folder / "text.toml").write_text("this is [not TOML\n")
    (folder / "afile").write_text("a file where a folder is expected\n")
    names = {"run": "run.h5", "tt": "tt.h5", "store": "store.h5", "text": "text.h5",
             "empty": "empty.h5", "json": "text.json", "toml": "text.toml",
             "afile": "afile"}  # fmt: skip
    return {key: str(folder / name) for key, name in names.items()}


def stub_work(monkeypatch) -> None:
    """Replace the entry points of real work by :class:`WorkStarted` (see the module doc)."""
    import vesicle.dynamics.simulation
    import vesicle.parallel
    import vesicle.solve.solver
    import vesicle.workflows.paper
    from vesicle.stokes.operators import LayerPotentials

    def stub(what):
        def refuse(*args, **kwargs):
            raise WorkStarted(what)

        return refuse

    monkeypatch.setattr(LayerPotentials, "__init__", stub("layer potentials"))
    originals = {
        "solve_flow": vesicle.solve.solver.solve_flow,
        "simulate": vesicle.dynamics.simulation.simulate,
        "local_cluster": vesicle.parallel.local_cluster,
    }
    for module in [m for name, m in sys.modules.items() if name.startswith("vesicle")]:
        for name, original in originals.items():
            if getattr(module, name, None) is original:
                monkeypatch.setattr(module, name, stub(name))
    for name in ("_compute_item", "_compute_concurrently"):
        monkeypatch.setattr(vesicle.workflows.paper, name, stub(f"paper item ({name})"))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, str]:
    return make_inputs(tmp_path_factory.mktemp("inputs"))


@pytest.fixture
def no_work(monkeypatch):
    stub_work(monkeypatch)


@pytest.fixture
def alarm():
    """Fail a case that takes longer than :data:`SECONDS`."""

    def expire(*_):
        raise TimeoutError(f"the case took more than {SECONDS} s: it is working, not checking")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(SECONDS)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


def invoke(args: str, inputs: dict, folder: Path, files: dict, monkeypatch):
    """``vesicle ARGS`` in ``folder`` (its working directory), with ``files`` written there."""
    for name, text in files.items():
        (folder / name).write_text(text)
    monkeypatch.chdir(folder)
    argv = shlex.split(args.format(**inputs))
    return CliRunner().invoke(main, argv, catch_exceptions=False)


# ------------------------------------------------------------------- the cases
def bad(args: str, match: str, files: dict | None = None, id: str | None = None):
    """A case refused before any work, with an error matching ``match`` (a regex)."""
    return pytest.param(args, match, files or {}, id=id or args)


def ok(args: str, files: dict | None = None, id: str | None = None):
    """A case accepted by documented behaviour: it gets to the work."""
    return pytest.param(args, files or {}, id=id or args)


def toml(**tables: str) -> dict:
    """A config file ``c.toml`` of ``tables`` (name -> body)."""
    return {"c.toml": "".join(f"[{name}]\n{body}\n" for name, body in tables.items())}


def sweep(body: str, task: str = "tt", **tables: str) -> dict:
    """A sweep config ``s.toml``: ``[sweep] task``, ``out = "s.h5"``, then ``body``."""
    head = f'[sweep]\ntask = "{task}"\nout = "s.h5"\n'
    return {"s.toml": head + body + "".join(f"[{k}]\n{v}\n" for k, v in tables.items())}


SMALL = "[discretisation]\ndegree = 2\ngrid = 8\n"

# fmt: off
REFUSED = [
    # --- vesicle run: Physics (v in (0, 1], lam > 0, chi finite: its docstring and --help)
    bad("run --v 0", r"reduced volume v"),
    bad("run --v -0.5", r"reduced volume v"),
    bad("run --v 1.5", r"reduced volume v"),
    bad("run --v nan", r"\bv\b"),
    bad("run --v inf", r"\bv\b"),
    bad("run --lam 0", r"\blam\b"),
    bad("run --lam -2", r"\blam\b"),
    bad("run --lam inf", r"\blam\b"),
    bad("run --chi nan", r"\bchi\b"),
    # the membrane's Boussinesq number: >= 0 and finite (Physics' docstring, --bq's help)
    bad("run --bq -1", r"\bbq\b"),
    bad("run --bq inf", r"\bbq\b"),
    bad("run --v abc", r"--v"),
    # Discretisation: grid >= 4, degree >= 2, grid >= 2 degree (its docstring)
    bad("run --grid 3", r"grid"),
    bad("run --grid 0", r"grid"),
    bad("run --degree 1", r"degree"),
    bad("run --grid 8 --degree 5", r"too coarse for degree"),
    bad("run --grid 8 --degree 8", r"too coarse for degree"),
    bad("run --grid 12.5", r"--grid"),
    bad("run --n-rot 1", r"n_rot"),
    bad("run --threads 0", r"workers"),
    bad("run --backend cuda", r"--backend"),
    bad("run --flow couette", r"--flow"),
    # run settings (RUN_DEFAULTS; --help of each option)
    bad("run --rtol 0", r"rtol"),
    bad("run --rtol -1e-4", r"rtol"),
    bad("run --rtol 5", r"rtol"),  # "local error per step, relative to the mean radius"
    bad("run --rtol 1", r"rtol"),
    bad("run --rtol nan", r"rtol"),
    bad("run --periods 1", r"periods"),  # --help: "at least 2"
    bad("run --periods -1", r"periods"),
    bad("run --t-end 0", r"t_end"),
    bad("run --t-end -1", r"t_end"),
    bad("run --t-end inf", r"t_end"),
    bad("run --save-every 0", r"save_every"),
    bad("run --save-every -0.1", r"save_every"),
    bad("run --dt-max 0", r"dt_max"),
    bad("run --dt-max -1", r"dt_max"),
    bad("run --dt-max 1e-9", r"dt_max"),  # below dt_min (1e-7)
    bad("run --perturb -0.1", r"perturb"),
    bad("run --perturb 0.01 --seed -1", r"seed"),  # numpy takes no negative seed
    bad("run --steady-tol -1", r"steady_tol"),
    bad("run --drift-tol -1", r"drift_tol"),
    bad("run --checkpoint-every 0", r"checkpoint_every"),
    bad("run --tilt nan", r"tilt"),
    bad("run --integrator rk4", r"--integrator"),
    bad("run --tolerances loose", r"--tolerances"),
    # --init: 'spheroid', 'tt', a steady-state file or FILE[:INDEX] (its --help)
    bad("run --init sphere", r"--init"),
    bad("run --init missing.h5", r"--init.*does not exist"),
    bad("run --init {text}", r"not a readable HDF5 file"),
    bad("run --init {empty}", r"not a readable HDF5 file"),
    bad("run --init {store}", r"not a vesicle run file"),
    bad("run --init {run}:99", r"no saved step '99'"),
    bad("run --init {run}:x", r"no saved step 'x'"),
    bad("run --init {tt} --grid 16 --degree 4", r"--init .*degree"),
    bad("run --init {tt} --v 0.9", r"--init .*v = "),
    # --resume: a run file; only --t-end may change (README)
    bad("run --resume missing.h5", r"--resume"),
    bad("run --resume {text}", r"not a readable HDF5 file"),
    bad("run --resume {tt}", r"not a vesicle run file"),
    bad("run --resume {run} --lam 2", r"--resume .*--lam"),
    # README: "--resume run.h5 --t-end 40  # continue"; this run is at t = 0.01 already
    bad("run --resume {run} --t-end 0.005", r"t.end"),
    # --config: unknown tables and keys, wrong types, values the objects refuse (config.py)
    bad("run --config missing.toml", r"no configuration file"),
    bad("run --config {toml}", r"not valid TOML"),
    bad("run --config {run}", r"not valid TOML"),
    bad("run --config c.toml", r"did you mean \[physics\]", toml(phyics="v = 0.9")),
    bad("run --config c.toml", r"unknown key 'lamda'.*did you mean 'lam'",
        toml(physics="lamda = 2"), id="run --config [physics] lamda"),
    bad("run --config c.toml", r"\[physics\] v must be", toml(physics='v = "0.9"'),
        id="run --config [physics] v string"),
    bad("run --config c.toml", r"rtol", toml(run="rtol = 5.0"), id="run --config [run] rtol 5"),
    bad("run --config c.toml", r"periods", toml(run="periods = 1"),
        id="run --config [run] periods 1"),
    bad("run --config c.toml", r"seed", toml(run="seed = -1"), id="run --config [run] seed -1"),
    bad("run --config c.toml", r"integrator", toml(run='integrator = "rk4"'),
        id="run --config [run] integrator"),
    bad("run --config c.toml", r"too coarse", toml(discretisation="grid = 6\ndegree = 4"),
        id="run --config [discretisation] coarse"),
    bad("run --config c.toml", r"schur", toml(solver="schur = 2.0"),
        id="run --config [solver] schur 2"),
    # outputs (README: refused before any work)
    bad("run --out nodir/r.h5", r"nodir.*does not exist"),
    bad("run --out /proc/r.h5", r"--out"),
    bad("run --out {run}", r"exists.*--overwrite"),
    bad("run --write-config {toml}", r"exists.*--overwrite"),
    bad("run --perturb 10", r"perturb"),  # a perturbation larger than the shape
    # --- vesicle tt
    bad("tt --v 0", r"reduced volume v"),
    bad("tt --lam 0", r"\blam\b"),
    bad("tt --bq -0.5", r"\bbq\b"),
    bad("tt --bq nan", r"\bbq\b"),
    bad("tt --chi 0", r"chi"),  # a steady TT state needs a flow
    bad("tt --grid 8 --degree 6", r"too coarse"),
    bad("tt --max-iterations 0", r"max_iterations"),
    bad("tt --workers 0", r"--workers"),
    bad("tt --modes all", r"--modes"),
    bad("tt --jacobian exact", r"--jacobian"),
    bad("tt --scheduler nonsense", r"nonsense"),
    bad("tt --out nodir/t.h5", r"nodir"),
    bad("tt --out {tt}", r"exists.*--overwrite"),
    bad("tt --config c.toml", r"unknown table \[run\]", toml(run="t_end = 1.0"),
        id="tt --config [run]"),
    bad("tt --config c.toml", r"\[physics\] lam", toml(physics='lam = "1:9"'),
        id="tt --config [physics] lam range"),
    # --- vesicle critical
    bad("critical --v 1.5", r"reduced volume v"),
    bad("critical --lam 8", r"No such option.*--lam"),
    bad("critical --bq -2", r"\bbq\b"),
    bad("critical --xtol 0", r"xtol"),  # --help: "Tolerance on lambda_c"
    bad("critical --xtol -1", r"xtol"),
    bad("critical --step 0", r"step"),
    bad("critical --lam0 -1", r"lam0|\blam\b"),
    bad("critical --max-iterations 0", r"max_iterations"),
    bad("critical --config c.toml", r"does not use \[physics\] lam", toml(physics="lam = 8.0"),
        id="critical --config [physics] lam"),
    # --- vesicle branch (--help: exactly one of --lam, --chi, --v a range or list)
    bad("branch --lam 7:8 --step 0", r"step"),
    bad("branch --lam 7:8 --step -0.5", r"step"),
    bad("branch --lam 7:8:0", r"step"),
    bad("branch --lam 7:7", r"--lam"),
    bad("branch --lam 1:9 --chi 1:3", r"exactly one.*--lam, --chi"),
    bad("branch", r"exactly one"),
    bad("branch --lam 1,x,3", r"--lam.*'x'"),
    bad("branch --lam 0:2", r"\blam\b"),
    bad("branch --lam 1:3 --bq -1", r"\bbq\b"),
    bad("branch --lam 1:nan", r"--lam"),
    bad("branch --v 0.9:1.2:0.1", r"reduced volume v"),
    bad("branch --lam 1:3 --chi nan", r"chi"),
    bad("branch --lam 1,2,4 --step 0.5", r"step"),  # --help: "Step size of a START:STOP range"
    bad("branch --lam 1:3 --xtol 0", r"xtol"),
    bad("branch --lam 1:3 --past-fold -1", r"past.fold"),  # --help: "Arclength steps"
    bad("branch --lam 1:3 --workers 0", r"--workers"),
    bad("branch --lam 1:3 --out nodir/b.json", r"nodir"),
    bad("branch --lam 1:3 --out {json}", r"exists.*--overwrite"),
    bad("branch --lam 1:3 --states {afile}", r"--states"),
    # --- vesicle neutral (--help: a list, or a range LOW:HIGH with --points)
    bad("neutral --chi 0:1", r"--chi"),
    bad("neutral --bq -1", r"\bbq\b"),
    bad("neutral --chi 10:0.1", r"--chi"),
    bad("neutral --chi 0.1:10 --points 1", r"--points"),
    bad("neutral --chi 1,2 --points 3", r"--points"),
    bad("neutral --chi 1,-2", r"--chi.*positive"),
    bad("neutral --chi 1 --continuation trace --cusps", r"--cusps applies to --continuation"),
    bad("neutral --chi abc", r"--chi"),
    bad("neutral --chi 0.1:10:2", r"--chi"),
    # --- vesicle neutral-bq (--help: --bq START:STOP[:STEP] or a list, >= 0; --lam-at positive)
    bad("neutral-bq --bq -1:2", r"--bq"),
    bad("neutral-bq --bq abc", r"--bq"),
    bad("neutral-bq --lam-at 0,1", r"--lam-at"),
    bad("neutral-bq --lam-min 0", r"--lam-min"),
    bad("neutral-bq --lam0 -1", r"--lam0"),
    bad("neutral-bq --v 1.5", r"\bv\b"),
    bad("neutral-bq --chi -1", r"chi"),
    bad("neutral-bq --out nodir/c.json", r"nodir"),
    bad("neutral-bq --out {json}", r"exists.*--overwrite"),
    bad("neutral --chi 1 --states {afile}", r"--states"),
    bad("neutral --v 1.1", r"reduced volume v"),
    bad("neutral --resume", r"--resume.*--out"),
    bad("neutral --chi 1 --xtol 0", r"xtol"),  # --help: "Absolute tolerance"
    bad("neutral --chi 1 --type-tol 0", r"type.tol"),  # --help: "Relative width in chi"
    bad("neutral --chi 1 --out {json}", r"exists.*--overwrite|--resume"),
    # --- vesicle sweep CONFIG.toml (docs/howto/sweeps.md: everything checked before any work)
    bad("sweep missing.toml", r"no sweep configuration"),
    bad("sweep {toml}", r"not valid TOML"),
    bad("sweep {run}", r"not valid TOML"),
    bad("sweep s.toml", r"needs a \[sweep\] table", {"s.toml": "[grid]\nlam = [1.0]\n"},
        id="sweep no [sweep]"),
    bad("sweep s.toml", r"task must be one of", sweep("[grid]\nlam = [1.0]\n", task="steady"),
        id="sweep unknown task"),
    bad("sweep s.toml", r"unknown key 'output'",
        {"s.toml": '[sweep]\ntask = "tt"\nout = "s.h5"\noutput = "x"\n[grid]\nlam = [1.0]\n'},
        id="sweep unknown [sweep] key"),
    bad("sweep s.toml", r'points must be "product" or "list"',
        {"s.toml": '[sweep]\ntask = "tt"\nout = "s.h5"\npoints = "zip"\n[grid]\nlam = [1.0]\n'},
        id="sweep points zip"),
    bad("sweep s.toml", r"\blam\b", sweep("[grid]\nlam = [0.0, 1.0]\n"), id="sweep lam 0"),
    bad("sweep s.toml", r"too coarse", sweep("[grid]\nlam = [1.0]\n[discretisation]\n"
                                             "grid = 4\ndegree = 4\n"), id="sweep coarse grid"),
    bad("sweep s.toml", r"unknown key 'modes'", sweep("[grid]\nlam = [1.0]\n[task]\n"
                                                      'modes = "general"\n'),
        id="sweep tt modes"),
    bad("sweep s.toml", r"max_iterations", sweep("[grid]\nlam = [1.0]\n[task]\n"
                                                 "max_iterations = 0\n"),
        id="sweep max_iterations 0"),
    bad("sweep s.toml", r"xtol", sweep("[grid]\nchi = [1.0]\n[task]\nxtol = 0.0\n",
                                       task="critical"), id="sweep critical xtol 0"),
    bad("sweep s.toml", r"lam0", sweep("[grid]\nchi = [1.0]\n[task]\nlam0 = -1.0\n",
                                       task="critical"), id="sweep critical lam0 -1"),
    bad("sweep s.toml", r"past_fold", sweep('[grid]\nchi = [1.0]\n[task]\nparameter = "lam"\n'
                                            'values = "1:3"\npast_fold = -1\n', task="branch"),
        id="sweep branch past_fold -1"),
    bad("sweep s.toml", r"values.*step", sweep('[grid]\nchi = [1.0]\n[task]\nparameter = "lam"\n'
                                               'values = "7:8:0"\n', task="branch"),
        id="sweep branch step 0"),
    bad("sweep s.toml", r"xtol", sweep("[grid]\nv = [0.95]\n[task]\nchi = [1.0]\nxtol = inf\n",
                                       task="neutral"), id="sweep neutral xtol inf"),
    bad("sweep s.toml", r"type_tol", sweep("[grid]\nv = [0.95]\n[task]\nchi = [1.0]\n"
                                           "type_tol = 0.0\n", task="neutral"),
        id="sweep neutral type_tol 0"),
    bad("sweep s.toml", r"chi", sweep('[grid]\nv = [0.95]\n[task]\nchi = "10:0.1"\n',
                                      task="neutral"), id="sweep neutral chi reversed"),
    bad("sweep s.toml", r"points", sweep('[grid]\nv = [0.95]\n[task]\nchi = "0.1:10"\n'
                                         "points = 1\n", task="neutral"),
        id="sweep neutral points 1"),
    bad("sweep s.toml", r"points", sweep("[grid]\nlam = [1.0]\n[task]\npoints = 0\n",
                                         task="ellipsoid_map"), id="sweep ellipsoid_map points 0"),
    bad("sweep s.toml", r"rtol", sweep("[grid]\nlam = [1.0]\n[run]\nrtol = 5.0\n", task="run"),
        id="sweep run rtol 5"),
    bad("sweep s.toml", r"flow", sweep('[grid]\nlam = [1.0]\n[physics]\nflow = "couette"\n'),
        id="sweep flow couette"),
    bad("sweep s.toml --workers 0", r"--workers", sweep("[grid]\nlam = [1.0]\n"),
        id="sweep --workers 0"),
    bad("sweep s.toml --workers 2 --scheduler tcp://127.0.0.1:8786", r"--workers.*--scheduler",
        sweep("[grid]\nlam = [1.0]\n"), id="sweep --workers and --scheduler"),
    bad("sweep s.toml --scheduler nonsense", r"--scheduler", sweep("[grid]\nlam = [1.0]\n"),
        id="sweep --scheduler nonsense"),
    bad("sweep s.toml --scheduler local", r"--scheduler.*--workers",
        sweep("[grid]\nlam = [1.0]\n"), id="sweep --scheduler local"),
    bad("sweep s.toml --csv", r"--csv goes with --table", sweep("[grid]\nlam = [1.0]\n"),
        id="sweep --csv"),
    bad("sweep s.toml", r"nodir", {"s.toml": '[sweep]\ntask = "tt"\nout = "nodir/s.h5"\n'
                                             "[grid]\nlam = [1.0]\n"}, id="sweep out nodir"),
    bad("sweep s.toml", r"s\.toml", {"s.toml": '[sweep]\ntask = "tt"\nout = "s.toml"\n'
                                              "[grid]\nlam = [1.0]\n"},
        id="sweep out is the config"),
    bad("sweep s.toml", r"s\.h5", {**sweep("[grid]\nlam = [1.0]\n"), "s.h5": "not HDF5\n"},
        id="sweep corrupt store"),
    # --- vesicle study (--help; vesicle study --list)
    bad("study nosuch", r"no study 'nosuch'"),
    bad("study {toml}", r"not valid TOML"),
    bad("study {run}", r"not valid TOML"),
    bad("study x.toml", r"needs a \[study\] table", sweep("[grid]\nlam = [1.0]\n") | {
        "x.toml": '[sweep]\ntask = "tt"\n[grid]\nlam = [1.0]\n'}, id="study no [study]"),
    bad("study x.toml", r"figure", {"x.toml": '[study]\nfigure = "pie"\ny = ["psi"]\n'
                                              '[sweep]\ntask = "tt"\n[grid]\nlam = [1.0]\n'},
        id="study figure pie"),
    bad("study tt-shape-lambda --degree 0", r"--degree"),
    bad("study tt-shape-lambda --degree 1", r"degree"),
    bad("study tt-shape-lambda --quick --grid 6", r"too coarse"),
    bad("study tt-shape-lambda --workers 0", r"--workers"),
    bad("study tt-shape-lambda --workers 2 --scheduler tcp://127.0.0.1:8786",
        r"--workers.*--scheduler"),
    bad("study tt-shape-lambda --scheduler nonsense", r"--scheduler"),
    bad("study tt-shape-lambda --out {afile}", r"--out"),
    # --- vesicle paper (--help; vesicle paper --list)
    bad("paper --only nosuch", r"nosuch"),
    bad("paper --only table1,fig99", r"fig99"),
    bad("paper --only ,", r"--only"),
    bad("paper --workers 0", r"--workers"),
    bad("paper --workers 2 --scheduler tcp://127.0.0.1:8786", r"--workers.*--scheduler"),
    bad("paper --scheduler nonsense", r"--scheduler"),
    bad("paper --out {afile}", r"--out"),
    # --- vesicle shape
    bad("shape", r"exactly one"),
    bad("shape --ellipsoid 1 1 1 --spheroid 0.9", r"exactly one"),
    bad("shape --spheroid 0", r"reduced volume|\bv\b"),
    bad("shape --spheroid 1.5", r"reduced volume|\bv\b"),
    bad("shape --ellipsoid 1 0 1", r"semi-axes|axes|positive"),
    bad("shape --ellipsoid 1 inf 1", r"semi-axes|axes|finite"),
    bad("shape --ellipsoid 1 1", r"--ellipsoid"),
    bad("shape --spheroid 0.9 --grid 2", r"grid"),  # a degree-1 "spheroid": the unit sphere
    bad("shape --spheroid 0.9 --grid 3", r"grid"),
    bad("shape --spheroid 0.9 --degree 1", r"degree"),  # the unit sphere, v = 1, not 0.9
    bad("shape --spheroid 0.9 --grid -4", r"grid"),
    bad("shape --spheroid 0.9 --degree -1", r"degree"),
    bad("shape --spheroid 0.9 --grid 8 --degree 12", r"degree"),
    # --- vesicle solve
    bad("solve --shape cube", r"unknown shape 'cube'"),
    bad("solve --shape ellipsoid:1,2", r"unknown shape"),
    bad("solve --shape ellipsoid:1,-1,1", r"semi-axes|axes|positive"),
    bad("solve --shape spheroid:1.5", r"reduced volume|\bv\b"),
    bad("solve --shape spheroid:x", r"cannot read the numbers"),
    bad("solve --lam 0", r"\blam\b"),
    bad("solve --bq -1", r"\bbq\b"),
    bad("solve --chi inf", r"\bchi\b"),
    bad("solve --tilt nan", r"tilt"),
    bad("solve --grid 2", r"grid"),
    bad("solve --shape spheroid:0.9 --degree 1", r"degree"),
    bad("solve --n-rot 1", r"n_rot|n-rot"),
    bad("solve --threads 0", r"workers|threads"),
    # --- vesicle analyze, plot, export, config: missing files, files of the wrong kind
    bad("analyze missing.h5", r"does not exist"),
    bad("analyze {text}", r"not a readable HDF5 file"),
    bad("analyze {empty}", r"not a readable HDF5 file"),
    bad("analyze {tt}", r"not a vesicle run file"),
    bad("analyze {store}", r"not a vesicle run file"),
    bad("analyze .", r"is a directory"),
    bad("plot missing.h5", r"does not exist"),
    bad("plot {text}", r"not a readable HDF5 file"),
    bad("plot {json}", r"not a readable HDF5 file|not a"),
    bad("plot {run} --with {json}", r"--with"),
    bad("plot {store}", r"'tt'"),  # --help: runs, steady states, branches, neutral curves
    bad("plot {run} --out {afile}", r"--out"),
    bad("export missing.h5 --vtk v", r"does not exist"),
    bad("export {text} --vtk v", r"not a readable HDF5 file"),
    bad("export {tt} --vtk v", r"not a vesicle run file"),
    bad("export {run}", r"--vtk"),
    bad("export {run} --vtk v --every 0", r"every"),
    bad("export {run} --vtk v --every -2", r"every"),
    bad("export {run} --vtk {afile}", r"--vtk"),
    bad("config missing.h5", r"does not exist"),
    bad("config {text}", r"not a readable HDF5 file"),
    bad("config {tt}", r"not a vesicle run file"),
    bad("config {store}", r"not a vesicle run file"),
    bad("config {run} --out {toml}", r"exists.*--overwrite"),
    bad("config {run} --out nodir/c.toml", r"nodir"),
]

DOCUMENTED = [
    # Physics docstring: chi is finite, "0 is rest"; a negative chi reverses the shear
    ok("run --chi 0"),
    ok("run --chi -1"),
    ok("run --v 1"),  # v in (0, 1]: the sphere is allowed
    ok("run --periods 0"),  # RUN_DEFAULTS: "0: never"
    ok("run --steady-tol 0"),  # --help: "(0: never)"
    ok("run --grid 10 --degree 4"),  # Discretisation: n_theta < 2 N + 4 is warned about only
    ok("run --config c.toml --lam 8", toml(physics="lam = 2.0"),
       id="run --config, an option given wins"),  # README: "options given win"
    ok("tt --chi -1"),
    ok("branch --lam 8:7 --step 0.5"),  # --step help: "which may run down (8:7)"
    ok("branch --lam 1,4,8"),  # README: a comma list
    ok("neutral --chi 1"),  # a list of one value
    ok("solve --shape sphere --lam 5"),  # README: Einstein
    ok("solve --shape sphere --degree 0"),  # the sphere at degree 0 is exact
    ok("paper --quick --only table1"),  # --help: "Compute only these items"
    ok("study tt-shape-lambda --quick"),  # README: vesicle study NAME --quick
    ok("sweep s.toml --workers 1", sweep("[grid]\nlam = [1.0, 2.0]\n" + SMALL),
       id="sweep tt"),
    # docs/howto/sweeps.md: "[grid] lists (or single values)"
    ok("sweep s.toml", sweep("[grid]\nlam = 2.0\n" + SMALL), id="sweep single value"),
]
# fmt: on


# -------------------------------------------------------------------- the tests
@pytest.mark.parametrize("args, match, files", REFUSED)
def test_refused_before_any_work(args, match, files, inputs, tmp_path, monkeypatch, no_work,
                                 alarm):  # fmt: skip
    try:
        r = invoke(args, inputs, tmp_path, files, monkeypatch)
    except WorkStarted as err:
        pytest.fail(f"`vesicle {args}` was accepted: it started work ({err})")
    assert r.exit_code != 0, f"`vesicle {args}` was accepted (exit 0): {r.output}"
    assert "Traceback" not in r.output, r.output
    errors = [line for line in r.stderr.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1, f"no one-line click error on stderr: {r.stderr!r}"
    assert re.search(match, errors[0], re.IGNORECASE), f"wrong reason: {errors[0]}"
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted(files), f"written before refusing: {set(left) - set(files)}"


@pytest.mark.parametrize("args, files", DOCUMENTED)
def test_documented_behaviour(args, files, inputs, tmp_path, monkeypatch, no_work, alarm):
    with pytest.raises(WorkStarted):
        r = invoke(args, inputs, tmp_path, files, monkeypatch)
        pytest.fail(f"`vesicle {args}` did not get to the work: {r.output}")


def test_enough_cases():
    """Issue 38 asks for at least 80 bad inputs across the commands."""
    assert len(REFUSED) >= 80
    commands = {p.values[0].split()[0] for p in REFUSED}
    assert commands >= {"run", "tt", "critical", "branch", "neutral", "sweep", "study", "paper",
                        "shape", "solve", "analyze", "plot", "export", "config"}  # fmt: skip
