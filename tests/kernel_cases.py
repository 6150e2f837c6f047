"""Shared by the kernel's differential tests: the compiled twins (or why they are
missing), bit-level equality, and the kernel inputs the sample programs make."""

from __future__ import annotations

import copy
import os
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from prsxy_post import kernel
from prsxy_post.convert import ConvertJob, convert_file

from .conftest import ROOT

#: CI sets it: a missing extension fails these tests instead of skipping them.
REQUIRE = os.environ.get("PRSXY_REQUIRE_COMPILED") == "1"


def compiled(name: str) -> ModuleType:
    """The compiled module ``prsxy_post.kernel.<name>``; skip (fail under
    PRSXY_REQUIRE_COMPILED=1) when the extension is not built."""
    try:
        mod = __import__(f"prsxy_post.kernel.{name}", fromlist=["_"])
    except ImportError as e:
        why = f"the compiled kernel is not built ({e}): pip install -e . builds it"
        if REQUIRE:
            pytest.fail(f"PRSXY_REQUIRE_COMPILED=1 but {why}")
        pytest.skip(why)
    return mod


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal to the bit (so 0.0 is not −0.0), NaN where the other has NaN."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return False
    na, nb = np.isnan(a), np.isnan(b)
    return bool(
        np.array_equal(na, nb) and np.array_equal(a[~na].view(np.int64), b[~nb].view(np.int64))
    )


#: sample programs × profiles, as the golden files are made
RUNS = [
    (s, fmt, "profiles/prsxy-shop.toml")
    for s in ("pocket.ngc", "drill.ngc", "five-axis.ngc")
    for fmt in ("pmac", "gcode")
] + [("five-axis.ngc", "pmac", "tests/data/vectors/perturbed.toml")]


def record(attr: str, tmp: Path) -> list[tuple[Any, ...]]:
    """The arguments of every call of the selected kernel ``kernel.<attr>``
    (``_inverse_rows``, ``_fixed_rows``) while the sample programs convert
    (:data:`RUNS`), in this process."""
    return record_many([attr], tmp)[attr]


def record_many(
    attrs: list[str], tmp: Path, runs: list[tuple[str, str, str]] | None = None
) -> dict[str, list[tuple[Any, ...]]]:
    """:func:`record` for several kernels in one conversion of the samples (or of
    ``runs``: sample, format, profile, as :data:`RUNS`)."""
    calls: dict[str, list[tuple[Any, ...]]] = {a: [] for a in attrs}

    def spy(attr: str) -> Callable[..., Any]:
        inner: Callable[..., Any] = getattr(kernel, attr)

        def call(*args: Any) -> Any:
            # deep copies: a record of arrays (TimeLaw, PathArrays) holds the
            # caller's arrays, which it may change later
            calls[attr].append(tuple(copy.deepcopy(a) for a in args))
            return inner(*args)

        return call

    mp = pytest.MonkeyPatch()
    for attr in attrs:
        mp.setattr(kernel, attr, spy(attr))
    try:
        for i, (sample, fmt, prof) in enumerate(RUNS if runs is None else runs):
            job = ConvertJob(
                str(ROOT / "samples" / sample), str(ROOT / prof), fmt, str(tmp / f"{i}.out")
            )
            convert_file(job)
    finally:
        mp.undo()
    return calls
