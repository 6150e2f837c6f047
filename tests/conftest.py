"""Shared fixtures: paths, profiles, random machines."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from prsxy_post import profile as profile_mod

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"
VECTORS = DATA / "vectors"
#: the project's shared folder (contract, paper, corpus) when a parent folder has
#: it (beside the main work tree, or above a worktree); the tests run without it
SHARED = next((p / "shared" for p in ROOT.parents if (p / "shared" / "corpus").is_dir()), None)


def read_vector_csv(path: Path) -> dict[str, np.ndarray]:
    """The contract's test vectors: '#' comments, then a header row."""
    rows = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    reader = list(csv.DictReader(rows))
    return {k: np.array([float(r[k]) for r in reader]) for k in reader[0]}


@pytest.fixture(scope="session")
def nominal() -> profile_mod.Profile:
    return profile_mod.loads(
        (ROOT / "profiles" / "prsxy-nominal.toml").read_text(), "prsxy-nominal.toml"
    )


@pytest.fixture(scope="session")
def perturbed() -> profile_mod.Profile:
    return profile_mod.loads((VECTORS / "perturbed.toml").read_text(), "perturbed.toml")
