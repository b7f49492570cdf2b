import math

import numpy as np
import pytest

from fluidnb._random import resolve_seed, rng
from fluidnb._validation import (
    check_array,
    check_choice,
    check_int,
    check_mask,
    check_range,
    check_vector_field,
)


def test_check_range_accepts_and_converts():
    assert check_range("rth", 0, 0, 1) == 0.0
    assert check_range("rth", np.float32(0.5), 0, 1) == 0.5
    assert isinstance(check_range("x", 3, 0, None), float)


@pytest.mark.parametrize(
    ("kwargs", "value", "message"),
    [
        ({"lo": 0, "hi": 1}, 1.3, r"rth must be in \[0, 1\], got 1.3"),
        ({"lo": 0, "hi": 1, "hi_open": True}, 1, r"rth must be in \[0, 1\), got 1"),
        ({"lo": 0, "lo_open": True}, 0, r"rth must be > 0, got 0"),
        ({"hi": 2}, 3, r"rth must be <= 2, got 3"),
        ({}, math.nan, "rth must be finite"),
        ({}, math.inf, "rth must be finite"),
        ({}, "0.3", "rth must be a real number"),
        ({}, True, "rth must be a real number"),
    ],
)
def test_check_range_messages(kwargs, value, message):
    with pytest.raises(ValueError, match=message):
        check_range("rth", value, **kwargs)


def test_check_int():
    assert check_int("T", 4.0, 2) == 4
    with pytest.raises(ValueError, match=r"T must be an integer, got 4\.5"):
        check_int("T", 4.5)
    with pytest.raises(ValueError, match=r"T must be an integer >= 2, got 1"):
        check_int("T", 1, 2)
    with pytest.raises(ValueError, match="T must be an integer"):
        check_int("T", False)


def test_check_choice():
    with pytest.raises(ValueError, match="mapping must be one of 'plane', 'convex', got 'x'"):
        check_choice("mapping", "x", ("plane", "convex"))


def test_check_array():
    with pytest.raises(ValueError, match=r"field must have 2 dimensions, got shape \(3,\)"):
        check_array("field", np.zeros(3), ndim=2)
    with pytest.raises(ValueError, match="field must not be empty"):
        check_array("field", np.zeros((0, 3)), ndim=2)
    with pytest.raises(ValueError, match=r"field contains 1 NaN"):
        check_array("field", np.array([[1.0, np.nan]]))
    with pytest.raises(ValueError, match="field must be a numeric array"):
        check_array("field", np.array(["a"]))


def test_check_mask():
    m = check_mask("region", np.array([[0.2, 0.7]]), (1, 2))
    assert m.dtype == bool
    assert m.tolist() == [[False, True]]
    with pytest.raises(ValueError, match="region is empty"):
        check_mask("region", np.zeros((2, 2), bool))
    with pytest.raises(ValueError, match=r"region must have the same height and width"):
        check_mask("region", np.ones((2, 2)), (3, 3))
    assert not check_mask("region", np.zeros((2, 2)), allow_empty=True).any()


def test_check_vector_field():
    assert check_vector_field("velocity", np.zeros((2, 3, 2), np.float32)).dtype == np.float32
    assert check_vector_field("velocity", np.zeros((2, 3, 2), int)).dtype == np.float64
    with pytest.raises(ValueError, match=r"velocity must have shape \(H, W, 2\)"):
        check_vector_field("velocity", np.zeros((2, 3, 3)))
    with pytest.raises(ValueError, match="velocity must have the same height and width"):
        check_vector_field("velocity", np.zeros((2, 3, 2)), (4, 4))


def test_rng_seeding():
    a = rng(7).random(5)
    b = rng(7).random(5)
    assert np.array_equal(a, b)
    g = np.random.default_rng(1)
    assert rng(g) is g
    assert not np.array_equal(rng(1).random(5), rng(2).random(5))
    for bad in (-1, 1.5, "3", True):
        with pytest.raises(ValueError, match="seed must be None, a non-negative integer"):
            rng(bad)


def test_resolve_seed_records_a_remakeable_int():
    assert resolve_seed(7) == 7
    fresh = resolve_seed(None)
    assert isinstance(fresh, int)
    assert 0 <= fresh < 2**31
    # None draws new entropy each time (two equal draws: 1 in 2**31)
    assert resolve_seed(None) != fresh or resolve_seed(None) != fresh
    # a Generator gives an int drawn from its stream: same stream, same int
    assert resolve_seed(np.random.default_rng(3)) == resolve_seed(np.random.default_rng(3))
    assert resolve_seed(np.random.default_rng(3)) != resolve_seed(np.random.default_rng(4))
    for bad in (-1, 1.5, "3", True):
        with pytest.raises(ValueError, match="seed must be None, a non-negative integer"):
            resolve_seed(bad)
