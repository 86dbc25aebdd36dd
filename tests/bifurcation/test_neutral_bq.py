"""lambda_c(Bq) by two-parameter continuation in (Bq, lambda) (vesicle.bifurcation.neutral_bq).

Independent references: ``vesicle critical`` (Brent's method on the leading growth rate of
vesicle.steady.stability, lambda bracketed at fixed Bq) at v = 0.95, chi = 3.162, N = 4 on 16x32,
xtol 1e-5: lambda_c = 8.590045 at Bq = 0 (xtol 1e-3: 8.59004, docs/notes/continuation-
measurements.md) and 7.5502789 at Bq = 1, both Hopf with omega_R = 1.2777 and 1.30869."""

import json
import math

import numpy as np
import pytest

import vesicle as vs
from vesicle.bifurcation.neutral_bq import neutral_curve_bq
from vesicle.model.theory import misbah_critical_lambda

DISC = vs.Discretisation(grid=16, degree=4)


@pytest.fixture(scope="module")
def curve():
    said = []
    c = neutral_curve_bq(vs.Physics(v=0.95, chi=3.162), [0.0, 1.0], DISC, lam_at=[7.5502789],
                         progress=said.append)  # fmt: skip
    return c, said


def test_the_curve_lands_on_the_bracketed_lambda_c(curve):
    c, said = curve
    assert not c.failed
    at = {p["bq"]: p for p in c.points}
    assert set(at) == {0.0, 1.0}
    for bq, lam_c, omega in ((0.0, 8.590045, 1.2777), (1.0, 7.5502789, 1.30869)):
        p = at[bq]
        assert p["located"] and p["residual"] < 1e-8 and p["bifurcation"] == "hopf"
        assert p["lambda_c"] == pytest.approx(lam_c, abs=2e-5)  # the brackets' xtol 1e-5
        assert p["omega_R"] == pytest.approx(omega, abs=2e-4)
        assert not p["other_unstable"]
    assert any("seed" in d for d in said) and any(d.get("curve") == "hopf" for d in said)


def test_the_critical_bq_at_a_lambda_is_solved_for_with_lambda_held(curve):
    c, _ = curve
    (q,) = c.critical_bq
    assert q["located"] and q["residual"] < 1e-8 and q["lam"] == 7.5502789
    assert q["bq"] == pytest.approx(1.0, abs=3e-5)  # 1e-5 in lambda over the slope 1.04


def test_its_json_carries_the_parameters_and_the_leading_order_line(curve):
    c, _ = curve
    d = json.loads(json.dumps(c.to_dict()))
    assert d["plane"] == ["bq", "lam"] and d["chi"] == 3.162 and d["v"] == 0.95
    assert d["degree"] == 4 and d["grid"] == 16 and "vesicle_version" in d
    assert d["curves"][0]["kind"] == "hopf" and d["seed"]["located"]
    # the leading-order line's data (docs/reference/membrane-viscosity.md §4: 16/23 at l = 2)
    assert d["leading_order"]["slope"] == pytest.approx(-16.0 / 23.0, rel=1e-15)
    assert d["leading_order"]["lambda_c_bq0"] == misbah_critical_lambda(0.95)


@pytest.mark.parametrize("kwargs, match", [
    ({"bq": [-1.0, 1.0]}, "bq must be"),
    ({"bq": [0.0, math.inf]}, "bq must be"),
    ({"bq": []}, "bq must be"),
    ({"lam_at": [0.0]}, "lam_at"),
    ({"form": "other"}, "form"),
    ({"lam_range": (2.0, 1.0)}, "lam_range"),
    ({"physics": vs.Physics(chi=-1.0)}, "chi must be positive"),
])  # fmt: skip
def test_bad_inputs_are_refused_before_any_work(kwargs, match):
    args = {"bq": [0.0, 1.0], **kwargs}
    bq = args.pop("bq")
    physics = args.pop("physics", vs.Physics())
    with pytest.raises(ValueError, match=match):
        neutral_curve_bq(physics, bq, DISC, **args)


def test_an_interrupted_curve_keeps_what_it_found(monkeypatch, tmp_path):
    """Ctrl-C during the continuation: the points of the curve under way come with the
    interruption (``complete: false``, no ``points``), and ``vesicle neutral-bq --out`` writes
    them before it exits with 130."""
    from click.testing import CliRunner

    import vesicle.bifurcation.neutral_bq as nbq
    from vesicle.cli import main

    def interrupted(physics, disc, bqs, lams, analysis, form, lam_range, settings, max_points,
                    lam0, say, *rest, **kwargs):  # fmt: skip
        say({"seed": {"bq": 0.0, "lambda_c": 8.0}})
        say({"curve": "hopf", "bq": 0.5, "lambda_c": 7.5, "located": True})
        raise KeyboardInterrupt

    monkeypatch.setattr(nbq, "_trace", interrupted)
    with pytest.raises(nbq.BqCurveInterrupted) as err:
        neutral_curve_bq(vs.Physics(), [0.0, 1.0], DISC)
    partial = err.value.partial
    assert partial["complete"] is False and "points" not in partial
    assert partial["seed"] == {"bq": 0.0, "lambda_c": 8.0}
    (curve,) = partial["curves"]
    assert curve["end"] == "interrupted" and curve["points"][0]["bq"] == 0.5
    out = tmp_path / "c.json"
    r = CliRunner().invoke(main, ["neutral-bq", "--bq", "0,1", "--degree", "4", "--grid", "16",
                                  "--out", str(out)])  # fmt: skip
    assert r.exit_code == 130, r.output
    written = json.loads(out.read_text())
    assert written["interrupted"] and written["curves"][0]["points"][0]["lambda_c"] == 7.5
    assert written["physics"]["v"] == 0.95 and "vesicle_version" in written


def test_the_command_keeps_its_evaluations_and_resumes(monkeypatch, tmp_path):
    """``vesicle neutral-bq --out c.json`` keeps the curve's evaluations in ``c.codim2/`` (the
    memo the library is given); interrupted, the same command is refused without ``--resume``
    (it would start over them) and with ``--resume`` is given the same folder back, with what
    it held; ``--resume`` needs ``--out`` and excludes ``--overwrite``."""
    from click.testing import CliRunner

    import vesicle.bifurcation.neutral_bq as nbq
    from vesicle.cli import main

    memos = []

    def interrupted(*args, memo=None, **kwargs):
        memos.append((memo, len(memo)))
        memo.save(memo.key("residual", float(len(memos))), np.zeros(3))
        raise KeyboardInterrupt

    monkeypatch.setattr(nbq, "_trace", interrupted)
    out = tmp_path / "c.json"
    args = ["neutral-bq", "--bq", "0,1", "--degree", "4", "--grid", "16", "--out", str(out)]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 130, r.output
    assert "--resume" in r.output
    assert memos[0][0].folder == tmp_path / "c.codim2" and memos[0][1] == 0
    r = CliRunner().invoke(main, args)
    assert r.exit_code != 0 and "--resume" in r.output and len(memos) == 1  # refused first
    r = CliRunner().invoke(main, [*args, "--resume"])
    assert r.exit_code == 130 and "replaying the 1 evaluations" in r.output
    assert memos[1][0].folder == tmp_path / "c.codim2" and memos[1][1] == 1
    for extra, says in ((["--resume", "--overwrite"], "--overwrite"),):
        r = CliRunner().invoke(main, [*args, *extra])
        assert r.exit_code != 0 and says in r.output
    r = CliRunner().invoke(main, [*args[:-2], "--resume"])
    assert r.exit_code != 0 and "give --out" in r.output
    r = CliRunner().invoke(main, [*args, "--overwrite"])  # the kept evaluations removed first
    assert r.exit_code == 130 and memos[-1][1] == 0
