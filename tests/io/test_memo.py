"""The evaluation memo (vesicle.io.memo): values kept by the content of their inputs.

Independent answers: a value kept is the array given (bit for bit); an input that differs in
one bit, its dtype or its shape is another key; a folder of another identity is refused; a
refused write stops the saving and not the computation."""

import errno

import numpy as np
import pytest

from vesicle.io.memo import EvaluationMemo, MemoMismatch


def test_a_kept_value_comes_back_bit_for_bit_and_is_counted(tmp_path):
    memo = EvaluationMemo(tmp_path / "m", {"v": 0.95})
    x = np.linspace(0.0, 1.0, 7)
    calls = []
    value = memo.cached("residual", lambda: calls.append(1) or np.sin(x) / 3.0, x)
    again = EvaluationMemo(tmp_path / "m", {"v": 0.95}).cached(
        "residual", lambda: pytest.fail("computed again"), x)
    assert calls == [1] and np.array_equal(again, np.sin(x) / 3.0) and again.dtype == float
    assert np.array_equal(value, again) and (memo.hits, memo.misses) == (0, 1)


def test_inputs_differing_in_one_bit_dtype_shape_or_name_are_other_keys():
    x = np.arange(6, dtype=float)
    y = x.copy()
    y[3] = np.nextafter(y[3], 10.0)
    keys = {EvaluationMemo.key("f", x), EvaluationMemo.key("f", y),
            EvaluationMemo.key("f", x.astype(np.float32)), EvaluationMemo.key("f", x.reshape(2, 3)),
            EvaluationMemo.key("g", x), EvaluationMemo.key("f", x[:3], x[3:])}  # fmt: skip
    assert len(keys) == 6
    assert EvaluationMemo.key("f", x) == EvaluationMemo.key("f", np.array(x, order="F"))


def test_a_folder_of_another_computation_is_refused(tmp_path):
    EvaluationMemo(tmp_path / "m", {"v": 0.95, "degree": 8})
    with pytest.raises(MemoMismatch, match="differs in degree"):
        EvaluationMemo(tmp_path / "m", {"v": 0.95, "degree": 6})


def test_a_full_disk_stops_the_saving_not_the_computation(tmp_path, monkeypatch, caplog):
    memo = EvaluationMemo(tmp_path / "m", {})

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(np, "save", full)
    assert memo.cached("f", lambda: np.ones(3), np.zeros(1)).sum() == 3.0
    assert memo.cached("f", lambda: np.ones(2), np.ones(1)).sum() == 2.0
    assert not memo.saving and len(memo) == 0
    assert sum("no longer kept" in r.message for r in caplog.records) == 1
    assert not list((tmp_path / "m").glob("*/*.tmp"))  # no partial file left
    memo.clear()
    assert not (tmp_path / "m").exists()


def test_a_record_comes_back_whole_or_not_at_all(tmp_path):
    """A search's result (several arrays, complex ones among them, and scalars with a NaN)
    comes back as it was kept; a record missing its meta or one of its arrays is a miss."""
    memo = EvaluationMemo(tmp_path / "m", {"who": "test"})
    arrays = {"x": np.arange(5.0), "v": np.array([1 + 2j, 3 - 1j])}
    meta = {"kind": "hopf", "converged": True, "iterations": 4, "tests": {"g": float("nan")}}
    memo.save_record("seed", (1.5,), arrays, meta)
    got, back = memo.load_record("seed", (1.5,))
    assert np.array_equal(got["x"], arrays["x"]) and np.array_equal(got["v"], arrays["v"])
    assert got["v"].dtype == complex
    assert back["kind"] == "hopf" and back["converged"] is True and back["iterations"] == 4
    assert np.isnan(back["tests"]["g"])
    assert memo.load_record("seed", (1.5000001,)) is None  # other inputs
    memo._path(memo.key("seed/v", 1.5)).unlink()  # a part lost: the record is not whole
    assert memo.load_record("seed", (1.5,)) is None
    memo._path(memo.key("seed/meta", 1.5)).unlink()
    assert memo.load_record("seed", (1.5,)) is None
