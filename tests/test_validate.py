"""follicle.validate: one wording for a bad single value, and ResourceError's place."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from follicle import FollicleError, InputError, ResourceError, SimulationError
from follicle.validate import is_whole, number, positive, whole


@pytest.mark.parametrize(
    ("value", "kwargs", "message"),
    [
        (True, {}, r"^x: expected a number \(got True\)$"),
        ("1", {"lo": 0.0, "unit": "s"}, r"^x: expected a number ≥ 0 s \(got '1'\)$"),
        (None, {}, r"^x: expected a number \(got None\)$"),
        (np.array(1.0), {}, r"^x: expected a number"),
        (float("nan"), {}, r"^x: must be finite \(got nan\)$"),
        (float("inf"), {"lo": 0.0}, r"^x: must be finite and ≥ 0 \(got inf\)$"),
        (10**400, {}, r"^x: must be finite \(got 1000.*\.\.\.\)$"),
        (-0.5, {"lo": 0.0, "unit": "s"}, r"^x: must be ≥ 0 s \(got -0.5\)$"),
        (0, {"lo": 0.0, "lo_open": True}, r"^x: must be > 0 \(got 0.0\)$"),
        (2.0, {"hi": 1.0}, r"^x: must be ≤ 1 \(got 2.0\)$"),
        (1.0, {"hi": 1.0, "hi_open": True}, r"^x: must be < 1 \(got 1.0\)$"),
        (1.5, {"lo": 0.0, "hi": 1.0}, r"^x: must be in \[0, 1\] \(got 1.5\)$"),
        (0.0, {"lo": 0.0, "hi": 180.0, "lo_open": True, "hi_open": True}, r"in \(0, 180\)"),
        (1e-7, {"lo": 1e-6}, r"^x: must be ≥ 1e-06 \(got 1e-07\)$"),
        ("x" * 1000, {}, r"^x: expected a number \(got 'x{50,60}\.\.\.\)$"),
    ],
)
def test_number_names_the_value_what_was_expected_and_what_was_got(value, kwargs, message):
    with pytest.raises(InputError, match=message):
        number(value, "x", **kwargs)


def test_number_returns_a_float_and_keeps_inclusive_bounds():
    for value in (0, 1, 0.5, np.float32(0.25), np.int64(1), np.uint8(0)):
        got = number(value, "x", lo=0.0, hi=1.0)
        assert type(got) is float and got == float(value)
    assert positive(0.0, "x", allow_zero=True) == 0.0
    with pytest.raises(InputError, match=r"^x: must be > 0 m \(got 0.0\)$"):
        positive(0.0, "x", unit="m")


@pytest.mark.parametrize(
    ("value", "args", "message"),
    [
        (0, (1, 65536), r"^spp: expected a whole number in 1..65536 \(got 0\)$"),
        (2.5, (1, None), r"^spp: expected a whole number ≥ 1 \(got 2.5\)$"),
        (2.0, (), r"^spp: expected a whole number \(got 2.0\)$"),
        (True, (0, 1), r"^spp: expected a whole number in 0..1 \(got True\)$"),
        (np.bool_(True), (), r"^spp: expected a whole number"),
        (9, (None, 8), r"^spp: expected a whole number ≤ 8 \(got 9\)$"),
    ],
)
def test_whole_refuses_fractions_bools_and_out_of_range(value, args, message):
    with pytest.raises(InputError, match=message):
        whole(value, "spp", *args)


def test_whole_returns_an_int_and_names_its_unit():
    got = whole(np.int64(2**40), "n", 0)
    assert type(got) is int and got == 2**40
    assert whole(2**64 - 1, "seed", 0, 2**64 - 1) == 2**64 - 1
    assert is_whole(np.uint16(3)) and not is_whole(True) and not is_whole(3.0)
    with pytest.raises(InputError, match=r"^shadow_size: expected texels in 16..4096 \(got 8\)$"):
        whole(8, "shadow_size", 16, 4096, what="texels")


def test_allow_none_passes_none_and_says_so_when_refusing():
    assert whole(None, "hair_limit", 0, allow_none=True) is None
    assert number(None, "time", allow_none=True) is None
    assert whole(3, "hair_limit", 0, allow_none=True) == 3
    assert number(0.5, "time", allow_none=True) == 0.5
    with pytest.raises(
        InputError, match=r"^hair_limit: expected a whole number ≥ 0 or None \(got -1\)$"
    ):
        whole(-1, "hair_limit", 0, allow_none=True)
    with pytest.raises(InputError, match=r"^time: expected a number ≥ 0 s or None \(got 'x'\)$"):
        number("x", "time", lo=0.0, unit="s", allow_none=True)
    with pytest.raises(InputError, match=r"^time: must be finite \(got nan\)$"):
        number(float("nan"), "time", allow_none=True)
    with pytest.raises(InputError, match=r"^n: expected a whole number \(got None\)$"):
        whole(None, "n")


def test_resource_error_is_its_own_follicle_error():
    assert issubclass(ResourceError, FollicleError)
    assert not issubclass(ResourceError, (InputError, SimulationError, MemoryError))


def test_a_request_too_big_for_memory_is_a_resource_error_and_one_cli_line(monkeypatch, tmp_path):
    from follicle.cli import main
    from follicle.groom import generator

    monkeypatch.setattr(generator, "_available_memory", lambda: 2**20)  # 1 MiB free
    scene = tmp_path / "scene.toml"
    scene.write_text("[groom]\ncount = 1000\n")
    out = tmp_path / "hair.npz"
    result = CliRunner().invoke(main, ["grow", str(scene), "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert result.output.startswith("error:") and result.output.count("\n") == 1
    assert "GiB are free" in result.output and "Groom.chunks()" in result.output
    assert not out.exists()
