"""ISO 230-2 analysis of laser runs: the real-axis tables and the figures of a positioning axis.

Laser runs (contract ``# kind: axis``) give, per motor, the position reached at each
target, approached from both directions over several runs, with no compensation
active. The contract's ``[[axis_comp]]`` table is then the mean deviation
(measured − target) per target and direction: ``forward`` from the + approaches,
``reverse`` from the − approaches.

ISO 230-2:2014 figures (all in mm), with x_ij↑/↓ the deviations at target i in run j:

    x̄_i↑, x̄_i↓          mean unidirectional deviations
    s_i↑, s_i↓          their standard deviations (n − 1)
    B_i = x̄_i↑ − x̄_i↓    reversal value;  B = max |B_i|,  B̄ = mean B_i
    E = max(x̄↑, x̄↓) − min(x̄↑, x̄↓)                      systematic deviation (bidirectional)
    M = max x̄_i − min x̄_i,  x̄_i = (x̄_i↑ + x̄_i↓) / 2     range of the mean deviation
    R_i = max(2 s_i↑ + 2 s_i↓ + |B_i|, 4 s_i↑, 4 s_i↓),  R = max R_i   repeatability
    A = max(x̄↑ + 2 s↑, x̄↓ + 2 s↓) − min(x̄↑ − 2 s↑, x̄↓ − 2 s↓)      accuracy
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import MeasurementError
from .profile import AxisComp


@dataclass(frozen=True)
class Iso2302Figures:
    motor: int
    n_runs: int
    targets: np.ndarray
    mean_forward: np.ndarray
    mean_reverse: np.ndarray
    reversal_B: float
    mean_reversal: float
    systematic_E: float
    range_M: float
    repeatability_R: float
    accuracy_A: float


def _per_target(
    motor: np.ndarray,
    target: np.ndarray,
    measured: np.ndarray,
    direction: np.ndarray,
    run: np.ndarray,
    m: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    sel = motor == m
    t = target[sel]
    dev = measured[sel] - t
    d = direction[sel]
    targets = np.unique(t)
    runs = len(np.unique(run[sel]))
    mf, mr, sf, sr = [], [], [], []
    for x in targets:
        up = dev[(t == x) & (d > 0)]
        dn = dev[(t == x) & (d < 0)]
        if len(up) < 2 or len(dn) < 2:
            raise MeasurementError(
                f"motor {m} at {x:g} mm has {len(up)} + and {len(dn)} − approaches",
                key=f"motor {m}",
                expected="at least 2 runs in each direction (ISO 230-2 asks for 5)",
            )
        mf.append(up.mean())
        mr.append(dn.mean())
        sf.append(up.std(ddof=1))
        sr.append(dn.std(ddof=1))
    return targets, np.array(mf), np.array(mr), np.array(sf), np.array(sr), runs


def tables_from_axis(
    motor: np.ndarray,
    target: np.ndarray,
    measured: np.ndarray,
    direction: np.ndarray,
    run: np.ndarray,
) -> list[AxisComp]:
    """The contract's [[axis_comp]] table of every motor in the runs.

    Parameters
    ----------
    motor, target, measured, direction, run : (N,) ndarrays
        One row per laser reading: motor number, commanded position [mm], measured
        position [mm], approach direction (+1 / −1) and run number.

    Returns
    -------
    One :class:`~prsxy_post.profile.AxisComp` per motor: forward = mean(measured −
    target) over the + approaches at each target, reverse over the − approaches.
    """
    out = []
    for m in sorted({int(x) for x in np.unique(motor)}):
        targets, mf, mr, _, _, _ = _per_target(motor, target, measured, direction, run, m)
        out.append(AxisComp(m, targets, mf, mr))
    return out


def iso230_2(
    motor: np.ndarray,
    target: np.ndarray,
    measured: np.ndarray,
    direction: np.ndarray,
    run: np.ndarray,
) -> dict[int, Iso2302Figures]:
    """ISO 230-2 bidirectional figures per motor (module docstring)."""
    out = {}
    for m in sorted({int(x) for x in np.unique(motor)}):
        targets, mf, mr, sf, sr, runs = _per_target(motor, target, measured, direction, run, m)
        b = mf - mr
        mean_bi = (mf + mr) / 2
        r_i = np.maximum(2 * sf + 2 * sr + np.abs(b), np.maximum(4 * sf, 4 * sr))
        out[m] = Iso2302Figures(
            motor=m,
            n_runs=runs,
            targets=targets,
            mean_forward=mf,
            mean_reverse=mr,
            reversal_B=float(np.max(np.abs(b))),
            mean_reversal=float(np.mean(b)),
            systematic_E=float(max(mf.max(), mr.max()) - min(mf.min(), mr.min())),
            range_M=float(mean_bi.max() - mean_bi.min()),
            repeatability_R=float(r_i.max()),
            accuracy_A=float(
                max((mf + 2 * sf).max(), (mr + 2 * sr).max())
                - min((mf - 2 * sf).min(), (mr - 2 * sr).min())
            ),
        )
    return out
