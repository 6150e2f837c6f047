"""Where a conversion's text goes (prsxy_post.sinks): the writer in this process
or in its own, the same bytes and the same first error either way, and nothing
left on disk by a conversion that fails."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import tomlkit

from prsxy_post import sinks
from prsxy_post.chain import Stages
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.errors import PrsxyError
from prsxy_post.points import PointChunk

ROOT = Path(__file__).resolve().parent.parent
SHOP = ROOT / "profiles" / "prsxy-shop.toml"


def _profile(tmp_path: Path, **pmac: int) -> str:
    doc = tomlkit.parse(SHOP.read_text())
    for key, value in pmac.items():
        doc["output"]["pmac"][key] = value  # type: ignore[index]
    path = tmp_path / "shop.toml"
    path.write_text(tomlkit.dumps(doc))
    return str(path)


def _program(tmp_path: Path, n: int, tail: list[str]) -> str:
    body = ["G21 G90 G1 F1500"] + [
        f"X{(i % 40) * 0.25:.2f} Y{(i % 9) * 0.5:.1f}" + (" G4 P0.01" if i % 500 == 0 else "")
        for i in range(1, n)
    ]
    path = tmp_path / "job.ngc"
    path.write_text("\n".join([*body, *tail, "M2"]) + "\n")
    return str(path)


def _run(
    program: str, prof: str, out: Path, parallel: bool, fmt: str = "pmac"
) -> dict[str, bytes] | str:
    """The files written (name → bytes), or the error's text."""
    job = ConvertJob(program, prof, fmt, str(out), None, Stages(), "", 700, parallel)
    try:
        written = convert_file(job).written
    except PrsxyError as err:
        return str(err)
    return {Path(w).name: Path(w).read_bytes() for w in written}


def _leftovers(d: Path) -> list[str]:
    return sorted(p.name for p in d.iterdir() if p.name.endswith(".tmp"))


@pytest.mark.parametrize("max_points", [0, 4000])
def test_the_writer_process_writes_the_same_bytes(tmp_path: Path, max_points: int) -> None:
    """One file, or a split program's parts: byte for byte the same."""
    prof = _profile(tmp_path, max_points_per_program=max_points)
    program = _program(tmp_path, 6000, [])
    here = _run(program, prof, tmp_path / "a" / "job.pmc", parallel=False)
    apart = _run(program, prof, tmp_path / "b" / "job.pmc", parallel=True)
    assert isinstance(here, dict) and isinstance(apart, dict)
    assert here == apart
    assert (len(here) > 1) == (max_points > 0)
    assert _leftovers(tmp_path / "a") == _leftovers(tmp_path / "b") == []


def test_the_writers_earlier_error_wins_over_the_chains_later_one(tmp_path: Path) -> None:
    """The writer refuses the third part (it would be PROG 1000, which Turbo PMAC
    calls for G codes); the chain finds a move out of reach at the program's end.
    In one process the writer's error comes first, as it is earlier in the
    program; with the writer behind in its own process, still the same error,
    and no file, part or temp file is left."""
    prof = _profile(tmp_path, max_points_per_program=3000, program=998)
    program = _program(tmp_path, 6000, ["G1 X900"])
    here = _run(program, prof, tmp_path / "a" / "job.pmc", parallel=False)
    apart = _run(program, prof, tmp_path / "b" / "job.pmc", parallel=True)
    assert isinstance(here, str) and "PROG 1000" in here
    assert apart == here
    for d in ("a", "b"):
        assert not (tmp_path / d).exists() or list((tmp_path / d).iterdir()) == []


def test_a_chain_error_stops_the_writer_process_and_leaves_nothing(tmp_path: Path) -> None:
    prof = _profile(tmp_path)
    program = _program(tmp_path, 6000, ["G1 X900"])
    out = tmp_path / "out" / "job.pmc"
    out.parent.mkdir()
    out.write_text("keep me")
    here = _run(program, prof, tmp_path / "a" / "job.pmc", parallel=False)
    apart = _run(program, prof, out, parallel=True)
    assert isinstance(here, str) and "job.ngc:6001:" in here
    assert apart == here
    assert out.read_text() == "keep me"
    assert _leftovers(out.parent) == []


def test_part_paths() -> None:
    assert sinks.part_path("a/x.pmc", 0, False) == "a/x.pmc"
    assert sinks.part_path("a/x.pmc", 2, True) == "a/x.part3.pmc"


def test_a_full_disk_reads_the_same_from_the_writer_process(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The disk fills up while the text is written: the same message (no
    traceback) whichever process writes, and no temp file is left. The forked
    writer inherits the patched method."""
    emit = sinks.Parts.emit
    calls = [0]

    def filling(self: sinks.Parts, pieces: list[sinks.Piece]) -> None:
        calls[0] += 1
        if calls[0] > 3:
            raise OSError(28, "No space left on device")
        emit(self, pieces)

    monkeypatch.setattr(sinks.Parts, "emit", filling)
    prof = _profile(tmp_path)
    program = _program(tmp_path, 6000, [])
    out = tmp_path / "out"
    here = _run(program, prof, out / "a.pmc", parallel=False)
    calls[0] = 0
    apart = _run(program, prof, out / "b.pmc", parallel=True)
    full = "cannot write output: No space left on device (expected a writable location)"
    assert here == f"{out / 'a.pmc'}: {full}"
    assert apart == here.replace("a.pmc", "b.pmc")
    assert list(out.iterdir()) == []


def test_leftovers_of_a_killed_writer_are_its_own_temp_files_only(tmp_path: Path) -> None:
    """What Parts names its temp files (one output, or a split one's parts) is
    removed; the output itself, another output's temp files and other files stay."""
    import tempfile

    mine = []
    for target in ("x.pmc", "x.part1.pmc", "x.part12.pmc"):
        fd, tmp = tempfile.mkstemp(prefix=f".{target}.", suffix=".tmp", dir=tmp_path)
        os.close(fd)
        mine.append(Path(tmp).name)
    others = ["x.pmc", ".y.pmc.abc.tmp", ".x.pmc.bak", ".x.partial.pmc.abc.tmp", ".xx.pmc.a.tmp"]
    for name in others:
        (tmp_path / name).write_text("keep")
    sinks.remove_leftovers(str(tmp_path / "x.pmc"))
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(others)
    sinks.remove_leftovers("-")  # standard output has no files


def test_the_writer_process_is_sent_only_what_its_writer_reads(tmp_path: Path) -> None:
    """The PMAC writer declares the point fields it reads, and only those cross to
    its process; the others arrive as None, so a field it read undeclared would
    fail the conversion. With machine functions, dwells and split parts (every
    field the writer uses), the bytes are those written in one process."""
    from prsxy_post.writers.pmac import PmacWriter

    assert set(PmacWriter.reads) < set(PointChunk.FIELDS)
    prof = _profile(tmp_path, max_points_per_program=4000)
    program = _program(tmp_path, 6000, ["S12000 M3", "G4 P0.5", "X1 Y1", "M5"])
    here = _run(program, prof, tmp_path / "a" / "job.pmc", parallel=False)
    apart = _run(program, prof, tmp_path / "b" / "job.pmc", parallel=True)
    assert isinstance(here, dict) and isinstance(apart, dict)
    assert len(here) > 1 and any("M3" in text.decode() for text in here.values())
    assert here == apart
    slim = sinks._chunk(sinks._fields(PointChunk.empty(), PmacWriter.reads))
    assert slim.P_cmd.shape == (0, 5) and slim.q is None


def test_the_gcode_writer_process_is_sent_only_what_its_writer_reads(tmp_path: Path) -> None:
    """The G-code writer declares the point fields it reads too (its FK's warm
    start, the lead it takes off, the stops, the feeds, the machine functions):
    the others arrive as None, so one it read undeclared would fail here. With
    machine functions, dwells and arcs, the bytes are those written in one
    process."""
    from prsxy_post.writers.linuxcnc import GcodeWriter

    assert set(GcodeWriter.reads) < set(PointChunk.FIELDS)
    prof = _profile(tmp_path)
    arcs = ["G1 X5 Y0"] + [f"G2 X{6 - i % 2} Y0 I{0.5 - i % 2} J0" for i in range(40)]
    program = _program(tmp_path, 6000, ["S12000 M3", "G4 P0.5", *arcs, "M5"])
    here = _run(program, prof, tmp_path / "a" / "job.ngc", parallel=False, fmt="gcode")
    apart = _run(program, prof, tmp_path / "b" / "job.ngc", parallel=True, fmt="gcode")
    assert isinstance(here, dict) and isinstance(apart, dict)
    text = here["job.ngc"].decode()
    assert "M3" in text and "G4" in text and "G2" in text
    assert here == apart


def test_a_channel_carries_arrays_whole_and_says_when_the_other_end_closed() -> None:
    """What crosses between the processes comes out equal, every kind of array a
    chunk holds (contiguous either way, strided, object, bool, empty), writable;
    a message eight times what the pipe holds (sent while the other end reads)
    whole; and a closed end is EOFError, as multiprocessing's Connection says it."""
    import threading

    import numpy as np

    recv, send = sinks.pipe(duplex=False)
    grid = np.arange(20.0).reshape(4, 5)
    sent = {
        "q": grid,
        "fortran": np.asfortranarray(grid),
        "strided": grid[:, ::2],
        "fn": np.array([None, (("M", 3.0),)], dtype=object),
        "dwell": np.array([True, False, True]),
        "split": np.arange(3, dtype=np.int8),
        "none": np.zeros((0, 5)),
        "big": np.random.default_rng(0).normal(size=(sinks.PIPE_BYTES,)),  # 8 x PIPE_BYTES
    }
    t = threading.Thread(target=send.send, args=(("chunk", sent, 7),), daemon=True)
    t.start()
    kind, got, n = recv.recv()
    assert (kind, n) == ("chunk", 7)
    for name, value in sent.items():
        assert got[name].dtype == value.dtype and got[name].shape == value.shape, name
        assert np.array_equal(got[name], value) if name != "fn" else list(got[name]) == list(value)
        assert got[name].flags.writeable, name
    t.join(timeout=30.0)
    assert not t.is_alive()  # everything sent was read
    send.close()
    with pytest.raises(EOFError):
        recv.recv()
    recv.close()


def test_a_part_is_put_on_disk_as_it_is_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each time SYNC_CHARS more of a part is written, everything written so far
    is in the file (Python's buffer flushed) when its data is synced, so the end
    waits only for the rest; the parts of a split output each on their own count,
    and the files hold the text whole."""
    synced: list[tuple[str, int]] = []

    def datasync(fd: int) -> None:
        synced.append((os.readlink(f"/proc/self/fd/{fd}"), os.fstat(fd).st_size))

    monkeypatch.setattr(sinks, "SYNC_CHARS", 100)
    monkeypatch.setattr(os, "fdatasync", datasync)
    parts = sinks.Parts(str(tmp_path / "x.pmc"), split=True)
    pieces = [(0, "a" * 60), (1, "b" * 150), (0, "c" * 60), (0, "d" * 30), (1, "e" * 10)]
    for piece in pieces:
        parts.emit([piece])
    first, second = parts.temps[0], parts.temps[1]
    # part 1 passes 100 characters at once (150), part 0 at its second piece (120)
    assert synced == [(second, 150), (first, 120)]
    parts.close()
    assert Path(first).read_text() == "a" * 60 + "c" * 60 + "d" * 30
    assert Path(second).read_text() == "b" * 150 + "e" * 10
