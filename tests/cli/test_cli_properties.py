"""Property-based tests of every command's inputs (issue 17, item 13): random bad input gets a
clear error and a non-zero exit code before any work, never a traceback.

Each test draws (option, bad value) pairs from strategies of values that the parameter objects
must refuse; ``max_examples`` says how many cases run (450 in all per run of the suite).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from vesicle.cli import main

OUT = Path(tempfile.mkdtemp(prefix="vesicle-cli-props-"))

_garbage = st.text(alphabet="abcxyz!@#$,;", min_size=1, max_size=6)
_nonfinite = st.sampled_from(["nan", "inf", "-inf"])


def _floats(**bounds):
    return st.floats(allow_nan=False, allow_infinity=False, **bounds).map(repr)


BAD = {
    "--v": st.one_of(_floats(max_value=0.0), _floats(min_value=1.0 + 1e-9), _nonfinite, _garbage),
    "--lam": st.one_of(_floats(max_value=0.0), _nonfinite, _garbage),
    "--chi": st.one_of(_nonfinite, _garbage),
    "--grid": st.one_of(st.integers(-5, 15).map(str), _garbage, st.just("32.5")),
    "--degree": st.one_of(st.integers(-5, 1).map(str), _garbage),
    "--n-rot": st.integers(-5, 1).map(str),
    "--threads": st.integers(-5, 0).map(str),
    "--backend": _garbage,
    "--flow": _garbage,
}
RUN_BAD = {
    **BAD,
    "--t-end": st.one_of(_floats(max_value=0.0), _nonfinite),
    "--save-every": st.one_of(_floats(max_value=0.0), _nonfinite),
    "--rtol": _floats(max_value=0.0),
    "--perturb": _floats(max_value=-1e-9),
    "--integrator": _garbage,
    "--dt-max": _floats(max_value=0.0),
}


def _check(args: list[str]) -> None:
    r = CliRunner().invoke(main, args)
    assert r.exit_code != 0, f"{args} was accepted"
    assert r.exception is None or isinstance(r.exception, SystemExit), f"{args}: {r.exception!r}"
    assert "Traceback" not in r.output and ("Error" in r.output or "error" in r.output), r.output


def _pairs(table):
    return st.sampled_from(sorted(table)).flatmap(lambda k: st.tuples(st.just(k), table[k]))


@settings(max_examples=150, deadline=None)
@given(_pairs(RUN_BAD))
def test_run_refuses_bad_input(pair):
    option, value = pair
    out = OUT / "never.h5"
    _check(["run", option, value, "--out", str(out), "--no-progress", "--no-plot"])
    assert not out.exists()


@settings(max_examples=100, deadline=None)
@given(_pairs({**BAD, "--chi": st.one_of(_nonfinite, _garbage, st.just("0"))}))
def test_tt_refuses_bad_input(pair):
    _check(["tt", *pair])


@settings(max_examples=80, deadline=None)
@given(_pairs({k: BAD[k] for k in BAD if k != "--lam"}))
def test_critical_refuses_bad_input(pair):
    _check(["critical", *pair])


@settings(max_examples=60, deadline=None)
@given(_pairs({k: BAD[k] for k in ("--lam", "--chi", "--n-rot", "--threads", "--backend")}))
def test_solve_refuses_bad_input(pair):
    _check(["solve", *pair])


@settings(max_examples=40, deadline=None)
@given(
    st.one_of(
        st.tuples(st.just("--ellipsoid"), st.lists(_floats(max_value=0.0), min_size=3, max_size=3)),
        st.tuples(st.just("--spheroid"), st.one_of(_floats(min_value=1.0 + 1e-9), _nonfinite)),
    )
)
def test_shape_refuses_bad_input(pair):
    option, value = pair
    _check(["shape", option, *([value] if isinstance(value, str) else value)])


@settings(max_examples=20, deadline=None)
@given(st.sampled_from(["analyze", "plot", "export"]), _garbage)
def test_file_commands_refuse_missing_or_foreign_files(command, name):
    foreign = OUT / f"{name}.h5"
    foreign.write_text("not HDF5")
    extra = ["--vtk", str(OUT / "vtk")] if command == "export" else []
    _check([command, str(foreign), *extra])
    _check([command, str(OUT / f"missing-{name}.h5"), *extra])
