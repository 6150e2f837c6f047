"""The chain's pieces: the output does not depend on how the program was fed.

The look-ahead commits blocks in runs that depend on the chunk size; the pieces
the chain makes points from must not (``interpolate.pieces``). Checked on the
pieces themselves, and on the bytes ``convert`` writes for random programs on a
machine with play, servo lag, real-axis tables and an error map, where a crossing
of a motor's play near a run's end once came out a few nm apart.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from prsxy_post import errormap, simulate
from prsxy_post import profile as profile_mod
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.interpolate import pieces
from prsxy_post.interpolate.geometry import Blocks
from prsxy_post.interpolate.lookahead import Plan
from prsxy_post.interpolate.sampling import Samples
from prsxy_post.interpolate.timelaw import TimeLaw

from .conftest import ROOT


def _plan_and_points(n_blocks: int, points_per_block: list[int]) -> tuple[Plan, Samples]:
    """A plan of n blocks (only the fields the cutting touches matter) and its
    points, each carrying its block's global number in ``line``."""
    fields = Blocks.FIELDS
    proto = {}
    for name in fields:
        proto[name] = np.arange(n_blocks, dtype=float)
    proto["dq_in"] = np.repeat(np.arange(n_blocks, dtype=float)[:, None], 5, axis=1)
    blocks = Blocks(**proto)
    law = TimeLaw(*(np.arange(n_blocks, dtype=float) for _ in TimeLaw._fields))
    block = np.repeat(np.arange(n_blocks), points_per_block)
    n = len(block)
    samples = Samples(
        **{name: np.zeros(n) for name in Samples.FIELDS if name != "block"},
        block=block,
    )
    samples = Samples(**{**samples.__dict__, "line": block.copy()})
    return Plan(blocks, law, np.full(5, -1.0)), samples


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.integers(1, 40), min_size=1, max_size=12),
    st.integers(1, 30),
    st.data(),
)
def test_pieces_begin_at_whole_multiples_however_the_runs_come(
    runs: list[int], size: int, data: st.DataObject
) -> None:
    total = sum(runs)
    per_block = data.draw(st.lists(st.integers(1, 3), min_size=total, max_size=total))
    plan, samples = _plan_and_points(total, per_block)
    cut = pieces.Pieces(size=size)
    made = []
    start = 0
    for i, n in enumerate(runs):
        part = plan.head(start + n).tail(start)
        lo, hi = np.searchsorted(samples.block, [start, start + n])
        pts = samples.take(slice(int(lo), int(hi)))
        pts = Samples(**{**pts.__dict__, "block": pts.block - start})
        cut.add(part, pts)
        made += cut.take(final=i == len(runs) - 1)
        start += n
    bounds = np.cumsum([0] + [len(p.blocks) for p, _ in made])
    assert bounds[-1] == total
    assert all(len(p.blocks) == size for p, _ in made[:-1])  # every piece whole but the last
    for (p, s), b0 in zip(made, bounds[:-1], strict=True):
        # the blocks, their points and the tangent after the piece are the plan's own
        assert np.array_equal(p.blocks.kind, plan.blocks.kind[b0 : b0 + len(p.blocks)])
        assert np.array_equal(s.line, s.block + b0)
        b1 = b0 + len(p.blocks)
        assert np.array_equal(
            p.next_dq_in, plan.blocks.dq_in[b1] if b1 < total else np.full(5, -1.0)
        )
    assert np.array_equal(np.concatenate([s.line for _, s in made]), samples.line)


@pytest.fixture(scope="module")
def machine_with_everything(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Contract errors, real-axis tables with backlash on every motor, bowed guides,
    servo lag and an error map: every stage that carries state from point to point."""
    nominal = profile_mod.loads((ROOT / "profiles" / "prsxy-nominal.toml").read_text(), "nominal")
    rng = np.random.default_rng(11)
    truth = simulate.random_machine(nominal, rng, axis_errors=True, effects=True, name="all")
    q = np.column_stack(
        [
            rng.uniform(-150, 150, (200, 2)),
            rng.uniform(-60, 40, 200),
            rng.uniform(-25, 25, (200, 2)),
        ]
    )
    err = rng.normal(0, 1e-3, q.shape) + 1e-3 * np.sin(q / 50.0)
    emap = errormap.fit(q, err, rng=rng, degrees=(2,), lambdas=[1e-4])
    effects = dict(truth.raw.get("effects", {}), servo_lag_ms=[0.4, 0.1, 0.3, 0.8, 0.5])
    doc = dict(truth.raw, effects=effects, error_map=emap.to_dict())
    path = tmp_path_factory.mktemp("machine") / "all.toml"
    path.write_text(profile_mod.dumps(doc))
    return path


@st.composite
def programs(draw: st.DrawFn) -> str:
    """Back-and-forth passes of short moves with tilts and small arcs: motors
    reverse often, so crossings of their play fall near every cut."""
    out = ["G21 G90 G17 G94 G64", "G0 X-10 Y-10 Z5 A0 B0", "G1 Z0 F1500"]
    x, y, a, b = -10.0, -10.0, 0.0, 0.0
    for _ in range(draw(st.integers(40, 160))):
        kind = draw(st.sampled_from(["x", "xy", "tilt", "arc", "feed"]))
        dx = draw(st.floats(-3.0, 3.0, allow_nan=False))
        x0, x = x, float(np.clip(x + dx, -40, 40))
        dx = x - x0  # as clipped: an arc needs a chord
        if kind == "xy":
            y = float(np.clip(y + draw(st.floats(-2.0, 2.0)), -40, 40))
            out.append(f"G1 X{x:.4f} Y{y:.4f}")
        elif kind == "tilt":
            a = float(np.clip(a + draw(st.floats(-2.0, 2.0)), -15, 15))
            b = float(np.clip(b + draw(st.floats(-2.0, 2.0)), -15, 15))
            out.append(f"G1 X{x:.4f} A{a:.4f} B{b:.4f}")
        elif kind == "arc" and abs(dx) > 0.2:
            r = abs(dx) * draw(st.floats(0.6, 3.0))
            out.append(f"{draw(st.sampled_from(['G2', 'G3']))} X{x:.4f} Y{y:.4f} R{r:.4f}")
        elif kind == "feed":
            out.append(f"G1 X{x:.4f} F{draw(st.sampled_from([300, 1200, 4000]))}")
        else:
            out.append(f"G1 X{x:.4f}")
    out += ["G0 Z5", "M2"]
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("fmt", ["pmac", "gcode"])
@settings(
    max_examples=12,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(programs(), st.lists(st.integers(1, 10**6), min_size=2, max_size=3), st.integers(5, 40))
def test_convert_writes_the_same_bytes_whatever_the_chunk_size(
    machine_with_everything: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    fmt: str,
    text: str,
    chunks: list[int],
    piece: int,
) -> None:
    """The program converted with every chunk size of [1, 7, *chunks]: the same
    bytes. The corrected G-code writer carries its state from chunk to chunk too
    (its lines held back, the forward kinematics' anchored starts: the anchors
    counted from the program's first point, an anchor's offset carried into the
    next chunk)."""
    # small pieces, so that a program of a few hundred points crosses many cuts
    monkeypatch.setattr(pieces, "PIECE_BLOCKS", piece)
    src = tmp_path / "p.ngc"
    src.write_text(text)
    outputs = {}
    for chunk in [1, 7, *chunks]:
        out = tmp_path / f"p{chunk}.out"
        convert_file(ConvertJob(str(src), str(machine_with_everything), fmt, str(out), chunk=chunk))
        outputs[chunk] = out.read_bytes()
    assert len(set(outputs.values())) == 1, {c: len(o) for c, o in outputs.items()}


@pytest.mark.parametrize(("chunk", "size"), [(7, 5), (3, 16), (50, 64), (1000, 4096)])
def test_a_pieces_points_are_the_points_of_the_runs_it_joins(chunk: int, size: int) -> None:
    """The chain makes a piece's points from its plan once it is whole (the steps
    of its blocks cut and joined with it, Planning.cut): they are the points of
    the runs the look-ahead committed, each sampled and joined, to the bit, field
    by field. The sample five-axis program with arcs and dwells, fed a few motions
    at a time."""
    from prsxy_post import chain, gcode, program
    from prsxy_post.interpolate.sampling import sample

    prof = profile_mod.loads((ROOT / "profiles" / "prsxy-shop.toml").read_text(), "shop")
    lines = ["G21 G90 G17 G94 G64", "G0 X-10 Y-10 Z5 A0 B0", "G1 Z0 F1500"]
    for i in range(120):
        x, a = 10.0 * math.sin(i / 7.0), 8.0 * math.cos(i / 11.0)
        lines.append(f"G1 X{x:.4f} Y{i * 0.2 - 10:.4f} A{a:.4f} B{a / 2:.4f}")
        if i % 17 == 5:
            lines.append(f"G2 X{x + 2:.4f} Y{i * 0.2 - 9:.4f} R{3 + i % 5}")
        if i % 41 == 7:
            lines.append("G4 P0.2")
    motions = gcode.interpret(
        "\n".join([*lines, "G0 Z5", "M2"]) + "\n", program.interpreter_config(prof)
    )
    planning = chain.Planning(prof)
    by_rows, by_points = pieces.Pieces(size=size), pieces.Pieces(size=size)
    made: list[tuple[Plan, Samples]] = []
    want: list[tuple[Plan, Samples]] = []
    for i in range(0, len(motions) + 1, chunk):
        final = i + chunk > len(motions)
        planned = planning.plan(chain.prepare(motions[i : i + chunk], prof, planning.limits), final)
        if planned.plan is not None and planned.steps is not None:
            by_rows.add(planned.plan, planned.steps)
            by_points.add(planned.plan, sample(planned.plan, planning.limits, planned.steps))
        for plan, steps in by_rows.take(final):
            assert isinstance(steps, np.ndarray) and len(steps) == len(plan.blocks)
            made.append((plan, sample(plan, planning.limits, steps)))
        want += by_points.take(final)  # type: ignore[arg-type]
    assert len(made) == len(want) > (2 if size <= 16 else 0)  # many pieces joined
    n_points = 0
    for (plan, got), (plan_w, s) in zip(made, want, strict=True):
        assert np.array_equal(plan.blocks.line, plan_w.blocks.line)
        for f in Samples.FIELDS:
            a, b = getattr(got, f), getattr(s, f)
            assert a.dtype == b.dtype, f
            if a.dtype.kind == "f":
                assert np.array_equal(a.view(np.int64), b.view(np.int64)), f
            else:
                assert np.array_equal(a, b), f
        n_points += len(got)
    assert n_points > 500
