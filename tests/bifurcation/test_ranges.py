"""The one range parser (vesicle.ranges): each spacing's values and its errors.

Expected values are written out by hand from the definitions in the module docstring
(arithmetic steps with STOP included, numpy-free linear/geometric spacing)."""

import numpy as np
import pytest

from vesicle.ranges import parse_range


@pytest.mark.parametrize(
    "text, step, expected",
    [("1:3", None, [1.0, 2.0, 3.0]), ("1:2", 0.4, [1.0, 1.4, 1.8, 2.0]),
     ("0.2,1,6", None, [0.2, 1.0, 6.0]), ("1:2:0.5", None, [1.0, 1.5, 2.0]),
     ("8:7", 0.5, [8.0, 7.5, 7.0]), ("8:7.2:0.5", None, [8.0, 7.5, 7.2]), ("3", None, [3.0]),
     ([1, 2, 4], None, [1.0, 2.0, 4.0])],
)  # fmt: skip
def test_stepped_ranges_and_lists(text, step, expected):
    np.testing.assert_allclose(parse_range(text, "step", step=step), expected)


def test_log_and_linear_ranges():
    np.testing.assert_allclose(parse_range("0.1:10", "log", points=3), [0.1, 1.0, 10.0])
    np.testing.assert_allclose(parse_range("-0.5:0.5", "linear", points=3), [-0.5, 0.0, 0.5])
    assert len(parse_range("0.1:10", "log")) == 10  # the documented default


@pytest.mark.parametrize(
    "text, spacing, kwargs, words",
    [("1:2", "step", {"step": 0}, "step must be a positive"),
     ("1:2", "step", {"step": -0.5}, "step must be a positive"),
     ("1:2:0", "step", {}, "step must be a positive"),
     ("1:2:0.1", "step", {"step": 0.2}, "gives its own step"),
     ("7:7", "step", {}, "equal"),
     ("1:x", "step", {}, "'x' is not a number"),
     ("", "step", {}, "no values"),
     ("nan,1", "step", {}, "finite"),
     ("1:2:3:4", "step", {}, "START:STOP"),
     ("2:1", "log", {}, "LOW < HIGH"),
     ("0:1", "log", {}, "0 < LOW"),
     ("1:3", "log", {"points": 1}, "at least 2"),
     ("1,2", "log", {"points": 3}, "points go with a range"),
     ("-1,2", "step", {"positive": True}, "positive"),
     ([True, 2], "step", {}, "not a number")],
)  # fmt: skip
def test_errors_say_what_is_wrong(text, spacing, kwargs, words):
    with pytest.raises(ValueError, match="--lam") as err:
        parse_range(text, spacing, name="--lam", **kwargs)
    assert words in str(err.value)
