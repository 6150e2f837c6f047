"""The compiled forward kinematics' arithmetic against its numpy reference: the same
bits.

The batched Newton of :func:`prsxy_post.kinematics.forward_platform` hands the
element-wise work between numpy's sines, cosines, matmuls and solve to the kernel
(``kernel/fk.py`` and its twin ``_fk.pyx``). Recorded inputs (every call the sample
programs make while converting to G-code, as the golden files are made), generated
ones (hypothesis: any angles, centres and struts, negative zero, tiny and huge
values, NaN and infinities), and whole forward solutions with either kernel.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post import kernel, kinematics, profile
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.kernel import fk

from .conftest import ROOT, VECTORS
from .kernel_cases import RUNS, compiled, same_bits

PROFILES = [ROOT / "profiles" / "prsxy-shop.toml", VECTORS / "perturbed.toml"]


def _geometry(path: Path) -> kinematics.Geometry:
    prof = profile.loads(path.read_text(), path.name)
    return kinematics.Geometry.from_params(prof.kinematics, prof.origin, prof.table, prof.effects)


def _same(got: tuple[np.ndarray, ...], want: tuple[np.ndarray, ...]) -> bool:
    return len(got) == len(want) and all(
        a.shape == b.shape and same_bits(a, b) for a, b in zip(got, want, strict=True)
    )


def _jacobian(out: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    """J's filled columns (the rest is the caller's), the cross products, the axes."""
    J, cu, cw, axes_t = out
    return J[:, :, :3], cu, cw, axes_t


NAMES = ("rotation_cs", "fk_equations", "fk_jacobian_parts", "newton_step")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[tuple[Any, ...]]]:
    """The arguments of every call of the FK's kernel functions while the sample
    programs convert to G-code (:data:`kernel_cases.RUNS`), in this process."""
    calls: dict[str, list[tuple[Any, ...]]] = {n: [] for n in NAMES}
    mp = pytest.MonkeyPatch()

    def spy(name: str) -> Callable[..., Any]:
        inner = getattr(kernel, name)

        def call(*args: Any) -> Any:
            calls[name].append(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args))
            return inner(*args)

        return call

    for name in NAMES:
        mp.setattr(kernel, name, spy(name))
    tmp = tmp_path_factory.mktemp("fk")
    try:
        for i, (sample, fmt, prof) in enumerate(RUNS):
            if fmt == "gcode":
                out = str(tmp / f"{i}.ngc")
                convert_file(ConvertJob(str(ROOT / "samples" / sample), str(ROOT / prof), fmt, out))
    finally:
        mp.undo()
    return calls


@pytest.mark.parametrize("name", NAMES)
def test_sample_programs_fk_is_bit_identical(
    recorded: dict[str, list[tuple[Any, ...]]], name: str
) -> None:
    _fk = compiled("_fk")
    calls = recorded[name]
    assert len(calls) >= 6  # every G-code run's Newton steps
    rows = 0
    for args in calls:
        want, got = getattr(fk, name)(*args), getattr(_fk, name)(*args)
        if name == "rotation_cs":
            want, got = (want,), (got,)
        if name == "fk_jacobian_parts":
            want, got = _jacobian(want), _jacobian(got)
        assert _same(got, want), f"{name}: compiled and reference differ"
        rows += len(args[1])
    assert rows > 5_000


VALUES = st.one_of(
    st.floats(-1e3, 1e3),
    st.sampled_from([0.0, -0.0, 5e-324, -1e-300, 1e300, np.inf, -np.inf, np.nan]),
)


def _rows(n: int, k: int) -> st.SearchStrategy[np.ndarray]:
    return hnp.arrays(np.float64, (n, k), elements=VALUES)


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_generated_fk_arithmetic_is_bit_identical(data: st.DataObject) -> None:
    _fk = compiled("_fk")
    n = data.draw(st.integers(0, 8))
    g, u, d = data.draw(_rows(3, 3)), data.draw(_rows(3, 3)), data.draw(_rows(3, 3))
    m = fk.FKArrays(g=g, u=u, d=d, L=data.draw(_rows(1, 3))[0])
    angles = data.draw(_rows(6, n))
    # R b_k as the kinematics has it: a transposed view of a matmul's result
    rb = data.draw(_rows(n, 9)).reshape(n, 3, 3).transpose(0, 2, 1)
    c = data.draw(_rows(n, 6))[:, :3]  # a view of x, as forward_platform passes it
    p3 = data.draw(_rows(n, 5))[:, :3]  # a view of P, as the kinematics passes it
    # straight guides (P_k d_k in the kernel) or the offsets of bowed ones
    off = data.draw(st.one_of(st.none(), _rows(n, 9).map(lambda a: a.reshape(n, 3, 3))))
    with np.errstate(all="ignore"):  # NaN and infinities: numpy warns, C does not
        R = fk.rotation_cs(*angles)
        assert _same((_fk.rotation_cs(*angles),), (R,))
        want = fk.fk_equations(m, c, rb, p3, off)
        assert _same(_fk.fk_equations(m, c, rb, p3, off), want)
        w, norm_w, _ = want
        args = (m, R, rb, w, norm_w, angles[2], angles[3])
        assert _same(
            _jacobian(_fk.fk_jacobian_parts(*args)), _jacobian(fk.fk_jacobian_parts(*args))
        )
        x, step = data.draw(_rows(n, 6)), data.draw(_rows(n, 6))
        limit = data.draw(st.sampled_from([1e-9, 0.0, 1e3, np.inf]))
        assert _same(_fk.newton_step(x, step, limit), fk.newton_step(x, step, limit))


@pytest.mark.parametrize("bow", [False, True], ids=["straight", "bowed"])
@pytest.mark.parametrize("path", PROFILES, ids=lambda p: p.stem)
def test_forward_kinematics_is_bit_identical_with_either_kernel(
    path: Path, bow: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Whole forward solutions (Newton from the nominal guess and warm-started, then
    the residual check) with the compiled arithmetic and with the reference; with
    straight guides and with bowed ones (``effects.guide_bow``)."""
    _fk = compiled("_fk")
    geo = _geometry(path)
    if bow:
        geo = dataclasses.replace(geo, guide_bow=np.array([0.004, -0.002, 0.003]))
    rng = np.random.default_rng(7)
    q = np.column_stack(
        [rng.uniform(-100, 100, (500, 2)), rng.uniform(-60, 0, 500), rng.uniform(-30, 30, (500, 2))]
    )
    P = kinematics.inverse(geo, q).P + rng.normal(0, 1e-3, (500, 5))
    guess = kinematics.platform_guess(kinematics.solve_platform(geo, q), q)
    results = {}
    for mod in (_fk, fk):
        monkeypatch.setattr(kernel, "_fk_mod", mod)
        results[mod] = (
            *kinematics.forward(geo, P),
            *kinematics.forward(geo, P, guess=guess),
            kinematics._fk_system(geo, P, guess)[1],
        )
    got, want = results[_fk], results[fk]
    assert np.all(want[1]) and np.all(want[3])  # every pose solved
    assert all(same_bits(a, b) for a, b in zip(got, want, strict=True))
