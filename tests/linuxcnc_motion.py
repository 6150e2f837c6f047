"""LinuxCNC's own motion controller, run headless on a written program.

`tests/controllers.py` runs corrected G-code as straight lines, each in exactly its
G93 time. A LinuxCNC machine does not: its trajectory planner (``tp.c``) re-times
the lines with its own velocity and acceleration limits, blends them within
``G64 P`` and samples the result once a servo cycle. This module runs the real
thing, the LinuxCNC 2.9 of Debian's ``linuxcnc-uspace`` (the package that gives
the tests ``rs274``), and records what it commands, cycle by cycle:

- The machine is ``trivkins`` over ``X Y Z A B`` (``[KINS] KINEMATICS = trivkins
  coordinates=XYZAB``), so the joint commands are the controller's Cartesian pose;
  the tests turn them into motor commands with the controller's own inverse
  kinematics, as a PRS-XY kinematics module would each servo cycle.
- POSIX non-realtime (``rtapi_app`` without a realtime kernel): the servo thread
  runs late or early on the wall clock, but the planner and the sampler run once per
  invocation with the nominal period, so sample k is at k x ``SERVO_PERIOD``.
  ``SERVO_PERIOD = 1000000`` ns, as LinuxCNC's sample configurations set it
  (``sim/axis/axis_mm.ini``).
- Limits: ``[AXIS_X/Y/Z]`` and ``[TRAJ]`` from the profile's tip limits
  (``max_feed_mm_min``, ``max_accel_mm_s2``), ``[AXIS_A/B]`` from its tilt limits
  (``rapid_deg_min``, ``max_accel_deg_s2``): the same limits the post-processor
  plans with.
- Each joint is homed where the program starts: with ``HOME_SEARCH_VEL = 0`` LinuxCNC
  homes a joint where it stands, its position set to ``HOME_OFFSET`` (LinuxCNC's
  homing configuration), and with ``HOME`` equal to it the joint stays there; the
  run checks that the commanded pose stood at the start before the program moved.
- HAL: ``joint.N.pos-cmd`` (the commanded joint position) and ``motion.program-line``
  (the line of the motion being executed) go into a ``sampler`` running last in the
  servo thread. ``halsampler`` prints floats with ``%f`` (six decimals, 1 nm: far
  too coarse for a velocity over 1 ms), so the positions pass a ``scale`` of 1e6
  on their way in.
- The display is a script that resets the estop, switches the machine on, homes,
  runs the program in AUTO mode and waits until the interpreter is idle and the
  motion queue empty (``linuxcnc`` Python module: ``stat``, ``command``,
  ``error_channel``).
- ``rtapi_app`` refuses to run as root without a fallback user; as root the run
  names ``nobody`` (``RTAPI_UID``) and puts the RTAPI socket in the run's own
  folder (``RTAPI_FIFO_PATH``).

One LinuxCNC runs at a time (a lock file): instances would share HAL and NML memory.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import pwd
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from prsxy_post.profile import MachineLimits

LINUXCNC = shutil.which("linuxcnc")
HALSAMPLER = shutil.which("halsampler")
#: the interpreter the display script runs under: Debian's, which has ``linuxcnc``
SYSTEM_PYTHON = "/usr/bin/python3"
SERVO_PERIOD_S = 1e-3
#: halsampler's ``%f`` keeps six decimals; the positions are scaled by this first
SCALE = 1e6
AXES = "XYZAB"


def available() -> bool:
    """Whether LinuxCNC's motion controller can run here."""
    if LINUXCNC is None or HALSAMPLER is None or not Path(SYSTEM_PYTHON).exists():
        return False
    probe = subprocess.run(
        [SYSTEM_PYTHON, "-c", "import linuxcnc"], capture_output=True, text=True, check=False
    )
    return probe.returncode == 0


@dataclass
class MotionRun:
    """What LinuxCNC commanded, one row per servo cycle from the start pose on.

    q : (m, 5) commanded pose [mm, mm, mm, deg, deg]
    t : (m,) time [s]
    line : (m,) line of the program file (1-based) whose motion was executing
    errors : the operator messages LinuxCNC raised
    """

    q: np.ndarray
    t: np.ndarray
    line: np.ndarray
    errors: list[str]
    #: status reads that failed and were recovered from (a new status channel each)
    failed_polls: int = 0

    @property
    def waiting(self) -> np.ndarray:
        """(m,) bool, the cycles the motion stood with its queue empty: at rest,
        executing no line (``motion.program-line`` 0). LinuxCNC's task feeds the
        queue at the host's pace, outside the servo thread; on a loaded machine it
        falls behind a program of short lines, and the planner waits (tp.c,
        tpHandleEmptyQueue)."""
        at_rest = np.r_[True, np.all(self.q[1:] == self.q[:-1], axis=1)]
        out: np.ndarray = at_rest & (self.line == 0)
        return out

    @property
    def waiting_s(self) -> float:
        """How long the motion stood with its queue empty between its first and last
        motion [s] (:attr:`waiting`). The planner's own time is ``t[-1]`` less this."""
        return float(np.count_nonzero(self.waiting) * SERVO_PERIOD_S)


_DISPLAY = r"""#!/usr/bin/python3
import os, subprocess, sys, time
import linuxcnc

program = os.environ["PRSXY_PROGRAM"]
samples = os.environ["PRSXY_SAMPLES"]
errors = os.environ["PRSXY_ERRORS"]
timeout = float(os.environ["PRSXY_TIMEOUT"])
c = linuxcnc.command()
e = linuxcnc.error_channel()
s = None
#: status reads that failed (a new status channel was opened after each)
failed_polls = 0
#: status reads to fail on purpose first, as a loaded machine's do (the tests'
#: check of the recovery below; 0 in every measuring run)
inject = int(os.environ.get("PRSXY_FAIL_POLLS", "0"))
broken = None


def poll():
    # stat.poll() checks the channel's last read before it reads again
    # (emcmodule.cc, poll: check_stat before peek), so once a read of the status
    # buffer failed on a loaded machine ("emcStatusBuffer invalid err=5",
    # NML_INTERNAL_CMS_ERROR) that channel fails every poll: open a new one
    global s, failed_polls, inject, broken
    for attempt in range(50):
        try:
            if s is None:
                s = linuxcnc.stat()
            if inject > 0 and s is not broken:
                inject -= 1
                broken = s  # as a real failed read leaves it: failing from now on
            if s is broken:
                raise linuxcnc.error("emcStatusBuffer invalid err=5 (injected)")
            s.poll()
            return True
        except linuxcnc.error:
            s = None
            failed_polls += 1
            time.sleep(0.02 * (attempt + 1))
    return False


def wait(cond, seconds):
    t0 = time.time()
    while time.time() - t0 < seconds:
        if poll() and cond():
            return True
        time.sleep(0.002)
    return False


def finish(code):
    with open(errors, "w") as f:
        while True:
            m = e.poll()
            if not m:
                break
            f.write(str(m[1]).replace("\n", " ") + "\n")
        if code:
            f.write(code + "\n")
    with open(errors + ".polls", "w") as f:
        f.write(str(failed_polls) + "\n")
    sys.exit(0)


# what a loaded machine may take to answer a command [s]; the waits below end as
# soon as the state is reached
SLOW = 60.0
c.state(linuxcnc.STATE_ESTOP_RESET)
c.wait_complete(SLOW)
c.state(linuxcnc.STATE_ON)
if not wait(lambda: s.task_state == linuxcnc.STATE_ON, SLOW):
    finish("the machine did not switch on")
c.home(-1)
if not wait(lambda: all(s.homed[:5]), SLOW):
    finish("the joints did not home")
c.mode(linuxcnc.MODE_AUTO)
c.wait_complete(SLOW)
if not wait(lambda: s.task_mode == linuxcnc.MODE_AUTO, SLOW):
    finish("the machine did not switch to AUTO")
sampler = subprocess.Popen(["halsampler", "-t"], stdout=open(samples, "w"))
c.program_open(program)
c.wait_complete(SLOW)
c.auto(linuxcnc.AUTO_RUN, 0)
started = wait(lambda: s.interp_state != linuxcnc.INTERP_IDLE, SLOW)
done = started and wait(
    lambda: s.interp_state == linuxcnc.INTERP_IDLE and s.queue == 0 and s.inpos, timeout)
time.sleep(0.05)
sampler.terminate()
sampler.wait()
finish("" if done else "the program did not finish in time")
"""


def _ini(limits: MachineLimits, start: np.ndarray) -> str:
    v_tip = limits.max_feed_mm_min / 60.0
    v_tilt = limits.rapid_deg_min / 60.0
    out = [
        "[EMC]\nVERSION = 1.1\nMACHINE = prsxy-post LinuxCNC oracle\n",
        "[DISPLAY]\nDISPLAY = ./display.py\n",
        "[TASK]\nTASK = milltask\nCYCLE_TIME = 0.001\n",
        "[RS274NGC]\nPARAMETER_FILE = sim.var\n",
        "[EMCMOT]\nEMCMOT = motmod\nCOMM_TIMEOUT = 1.0\n"
        f"SERVO_PERIOD = {round(SERVO_PERIOD_S * 1e9)}\n",
        "[EMCIO]\nEMCIO = io\nCYCLE_TIME = 0.100\nTOOL_TABLE = sim.tbl\n",
        "[HAL]\nHALFILE = sim.hal\n",
        "[TRAJ]\nCOORDINATES = X Y Z A B\nLINEAR_UNITS = mm\nANGULAR_UNITS = degree\n"
        f"MAX_LINEAR_VELOCITY = {v_tip!r}\nMAX_LINEAR_ACCELERATION = {limits.max_accel_mm_s2!r}\n",
        "[KINS]\nKINEMATICS = trivkins coordinates=XYZAB\nJOINTS = 5\n",
    ]
    for j, ax in enumerate(AXES):
        v, a = (v_tip, limits.max_accel_mm_s2) if j < 3 else (v_tilt, limits.max_accel_deg_s2)
        home = float(start[j])
        out.append(
            f"[AXIS_{ax}]\nMAX_VELOCITY = {v!r}\nMAX_ACCELERATION = {a!r}\n"
            "MIN_LIMIT = -100000\nMAX_LIMIT = 100000\n"
            f"[JOINT_{j}]\nTYPE = {'LINEAR' if j < 3 else 'ANGULAR'}\n"
            f"MAX_VELOCITY = {v!r}\nMAX_ACCELERATION = {a!r}\n"
            "MIN_LIMIT = -100000\nMAX_LIMIT = 100000\nFERROR = 1e9\nMIN_FERROR = 1e9\n"
            f"HOME = {home!r}\nHOME_OFFSET = {home!r}\nHOME_SEARCH_VEL = 0\n"
            "HOME_LATCH_VEL = 0\nHOME_SEQUENCE = 0\n"
        )
    return "".join(out)


def _hal() -> str:
    lines = [
        "loadrt [KINS]KINEMATICS",
        "loadrt [EMCMOT]EMCMOT servo_period_nsec=[EMCMOT]SERVO_PERIOD num_joints=[KINS]JOINTS",
        "loadrt scale count=5",
        "loadrt sampler depth=200000 cfg=fffffs",
        "addf motion-command-handler servo-thread",
        "addf motion-controller servo-thread",
    ]
    for j in range(5):
        lines += [
            f"addf scale.{j} servo-thread",
            f"setp scale.{j}.gain {SCALE:g}",
            f"net motor{j} joint.{j}.motor-pos-cmd => joint.{j}.motor-pos-fb",
            f"net cmd{j} joint.{j}.pos-cmd => scale.{j}.in",
            f"net scaled{j} scale.{j}.out => sampler.0.pin.{j}",
        ]
    lines += [
        "addf sampler.0 servo-thread",
        "net line motion.program-line => sampler.0.pin.5",
        "net estop iocontrol.0.user-enable-out => iocontrol.0.emc-enable-in",
        "net prepare iocontrol.0.tool-prepare => iocontrol.0.tool-prepared",
        "net change iocontrol.0.tool-change => iocontrol.0.tool-changed",
    ]
    return "\n".join(lines) + "\n"


#: tools 1-99 with no length: corrected G-code carries the tool lengths in its points
_TOOLS = "".join(f"T{n} P{n} Z0 D0\n" for n in range(1, 100))


class HostError(RuntimeError):
    """LinuxCNC did not come up to run the program (the host, not the program)."""


#: the display's own messages when LinuxCNC did not come up (not the program's)
_HOST_MESSAGES = (
    "the machine did not switch on",
    "the joints did not home",
    "the machine did not switch to AUTO",
)
#: how often a run is tried when LinuxCNC did not come up on a loaded host
ATTEMPTS = 3


def run(
    text: str, limits: MachineLimits, start: np.ndarray, timeout_s: float, fail_polls: int = 0
) -> MotionRun:
    """Run ``text`` on LinuxCNC, homed at the pose ``start``; what it commanded.

    ``timeout_s`` bounds the program's own run (it runs in real time). Where
    LinuxCNC did not come up (on a loaded host its processes may miss their
    start-up waits), the run is tried again, up to ``ATTEMPTS`` times; the samples
    are the servo cycles of the run that ran, so a retry changes no figure."""
    if not available():
        raise RuntimeError("LinuxCNC's motion controller is not installed")
    for attempt in range(ATTEMPTS):
        try:
            return _run_once(text, limits, start, timeout_s, fail_polls)
        except HostError:
            if attempt == ATTEMPTS - 1:
                raise
    raise AssertionError("unreachable")


def _run_once(
    text: str, limits: MachineLimits, start: np.ndarray, timeout_s: float, fail_polls: int
) -> MotionRun:
    start = np.asarray(start, dtype=float)
    lock = Path(tempfile.gettempdir()) / "prsxy-linuxcnc.lock"
    with open(lock, "w") as held, tempfile.TemporaryDirectory(prefix="prsxy-lcnc-") as tmp:
        fcntl.flock(held, fcntl.LOCK_EX)
        d = Path(tmp)
        os.chmod(d, 0o777)
        files = {
            "sim.ini": _ini(limits, start),
            "sim.hal": _hal(),
            "sim.tbl": _TOOLS,
            "sim.var": "",
            "display.py": _DISPLAY,
            "program.ngc": text,
        }
        for name, body in files.items():
            (d / name).write_text(body)
            os.chmod(d / name, 0o755 if name == "display.py" else 0o666)
        env = dict(
            os.environ,
            PRSXY_PROGRAM=str(d / "program.ngc"),
            PRSXY_SAMPLES=str(d / "samples.txt"),
            PRSXY_ERRORS=str(d / "errors.txt"),
            PRSXY_TIMEOUT=repr(float(timeout_s)),
            PRSXY_FAIL_POLLS=str(int(fail_polls)),
            # LinuxCNC writes its logs (linuxcnc_print.txt, linuxcnc_debug.txt) there
            HOME=str(d),
        )
        if os.geteuid() == 0:
            env["RTAPI_UID"] = str(pwd.getpwnam("nobody").pw_uid)
            env["RTAPI_FIFO_PATH"] = str(d / "rtapi_fifo")
        with contextlib.suppress(subprocess.TimeoutExpired):
            subprocess.run(
                [LINUXCNC, "sim.ini"],
                cwd=d,
                env=env,
                capture_output=True,
                text=True,
                timeout=timeout_s + 120.0,
                check=False,
            )
        errors_file = d / "errors.txt"
        if not errors_file.exists() or not (d / "samples.txt").exists():
            log = d / "linuxcnc_debug.txt"
            tail = log.read_text(errors="replace").splitlines()[-15:] if log.exists() else []
            raise HostError("LinuxCNC did not run the program:\n" + "\n".join(tail))
        errors = [e for e in errors_file.read_text().splitlines() if e]
        polls_file = d / "errors.txt.polls"
        failed = int(polls_file.read_text()) if polls_file.exists() else 0
        if any(e in _HOST_MESSAGES for e in errors):
            raise HostError(f"LinuxCNC did not come up: {errors}")
        raw = np.loadtxt(d / "samples.txt", ndmin=2)
    q = raw[:, 1:6] / SCALE
    line = raw[:, 6].astype(int)
    # the sampler runs from the start of HAL: the cycles before homing (at zero) and
    # the homing itself are not the program's; then from the last cycle at rest
    # before the first motion to the first at rest after the last
    homed = np.flatnonzero(
        np.all(np.abs(q - start) <= 1e-9 * np.maximum(1.0, np.abs(start)), axis=1)
    )
    if len(homed) == 0:
        raise RuntimeError(f"LinuxCNC never stood at the start pose {start}: {errors}")
    q, line = q[homed[0] :], line[homed[0] :]
    moved = np.flatnonzero(np.any(q[1:] != q[:-1], axis=1))
    a, b = (0, 1) if len(moved) == 0 else (int(moved[0]), int(moved[-1]) + 2)
    q, line = q[a:b], line[a:b]
    return MotionRun(q, np.arange(len(q)) * SERVO_PERIOD_S, line, errors, failed)


def motion_lines(text: str) -> dict[int, int]:
    """File line (1-based) -> index of the written point that line ends at, for
    every G0/G1/G2/G3/G4 line (the points `tests.controllers.run_gcode` reads)."""
    out: dict[int, int] = {}
    k = -1
    for no, raw in enumerate(text.splitlines(), 1):
        if raw.strip().startswith(("G0 ", "G1 ", "G2 ", "G3 ", "G4 ")):
            k += 1
            out[no] = k
    return out


def named_segments(run_: MotionRun, text: str) -> np.ndarray:
    """For each cycle, the written point ending the segment LinuxCNC's planner
    names (``motion.program-line``), (m,): before the first motion line the first
    segment, after a line that names none the last one named."""
    of = motion_lines(text)
    seg = np.array([of.get(int(n), -1) for n in run_.line])
    first_known = np.flatnonzero(seg >= 0)
    seg[: first_known[0] if len(first_known) else len(seg)] = 1
    return np.maximum(np.maximum.accumulate(seg), 1)


def segments(
    run_: MotionRun, named: np.ndarray, points: np.ndarray, arcs: dict | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """For each cycle, the written point whose segment it is in, (m,), and the
    commanded pose's distance from that segment [mm, a degree weighing as a µm].

    ``motion.program-line`` names the segment being executed (``named``,
    :func:`named_segments`); in a blend two are, so the nearer of the named one
    and its neighbours (in pose space, a degree weighing as a µm) is taken.
    ``arcs``: the G2/G3 moves by the point they end at
    (`tests.controllers.GcodeRun.arcs`), whose distance is to the arc."""
    seg = named
    best = np.full(len(seg), np.inf)
    out = seg.copy()
    w = np.array([1.0, 1.0, 1.0, 1e-3, 1e-3])
    # segments that are arcs, counted up to each point: an arc is long, so the
    # segment executing is the named one or next to it; farther candidates are
    # only taken over lines (a blend over several short ones)
    is_arc = np.zeros(len(points), dtype=int)
    is_arc[list(arcs or {})] = 1
    arcs_upto = np.cumsum(is_arc)
    for off in range(-3, 4):
        k = np.clip(seg + off, 1, len(points) - 1)
        lo, hi = np.minimum(seg, k), np.maximum(seg, k)
        past_an_arc = (arcs_upto[hi] - arcs_upto[lo - 1] > 0) & (abs(off) > 1)
        a, b = points[k - 1], points[k]
        ab = b - a
        n2 = np.einsum("ij,ij->i", ab, ab)
        u = np.clip(np.einsum("ij,ij->i", run_.q - a, ab) / np.where(n2 > 0, n2, 1.0), 0.0, 1.0)
        d = np.linalg.norm((run_.q - (a + u[:, None] * ab)) * w, axis=1)
        for j, arc in (arcs or {}).items():
            on = np.flatnonzero(k == j)
            if len(on):
                d[on] = arc.distance(points[j - 1], points[j], run_.q[on], w[3])
        d[past_an_arc] = np.inf
        nearer = d < best - 1e-15
        best[nearer] = d[nearer]
        out[nearer] = k[nearer]
    return out, best
