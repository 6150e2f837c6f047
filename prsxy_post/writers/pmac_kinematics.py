"""The calibrated machine inside the Turbo PMAC: one download file for coordinate
system 1 with its ``OPEN FORWARD`` and ``OPEN INVERSE`` programs (the paper's
"inverse kinematics transformation directly embedded in the Turbo PMAC").

The controller's rules (SRM = Turbo PMAC/PMAC2 Software Reference, TUM = Turbo
PMAC User Manual, "Setting Up a Coordinate System", "Kinematic Calculations"):

- ``#n->I`` makes motor n an inverse-kinematic axis: "at the end of each execution
  of the inverse-kinematic program ... Turbo PMAC expects to find the motor
  position calculated by the program for each Motor xx ... in variable Pxx"
  (SRM ``#{constant}->I``), in counts.
- The inverse program receives the programmed axis positions in the coordinate
  system's Q1–Q9 (A, B, C, U, V, W, X, Y, Z, engineering units) and runs "each
  programmed move or move segment" (SRM ``Isx50``; TUM "Conversion from Axis to
  Motor Position": "in the case of segmented moves, every segment of the move").
  With segmentation on (``Isx13`` > 0, ms) the segments are Isx13 long and the
  motors are splined between their ends (fine interpolation).
- The forward program runs at R, S and PMATCH: "Before running the program PMAC
  will place the commanded position value (in counts) for each Motor xx ... into
  global variable Pxx. After the program is run, Turbo PMAC will take the values
  in Q1 – Q9 ... as the starting positions" (SRM ``OPEN FORWARD``).
- Reserved: P1–P32 and Q1–Q10 (TUM "Reserved Variables"); this file's work
  variables are Q20 and up (the coordinate system's own, SRM ``Q{data}=``).
- An iterative forward solution must not loop without end: "if the solution does
  not converge in the expected number of cycles, the program should be stopped"
  (TUM "Iterative Solutions"); the programs stop it by setting the coordinate
  system's run-time error bit, ``M5182->Y:$00203F,22,1`` for C.S. 1 (TUM, the
  forward-kinematic example).
- ``I15`` selects degrees (0) or radians (1) for SIN, COS, ASIN, ACOS, ATAN2
  (SRM ``I15``); the programs are written for I15 = 0, the angles of the G-code.
- ``ATAN2({expression})`` takes its second (cosine) argument from Q0 (SRM,
  mathematical functions): ``Q0=c`` then ``ATAN2(s)`` is atan2(s, c).

The programs are the contract's kinematics, written out with the profile's
calibrated numbers as constants: the closed-form inverse (:mod:`prsxy_post.kinematics`)
with the platform's parasitic spin; the guide bows (6 Newton steps per leg, as
``kinematics._bowed_guides``) and the table's squareness, scales and
straightness (4 fixed-point steps, as ``kinematics.table_motors``); the
virtual-axis map Q' = Q − e(Q) of Eq. 5–6, as ``chain.correct_virtual`` does,
its Legendre polynomials by their three-term recurrence and its clamp to the
fitted domain as (|u+1| − |u−1|)/2. The forward program solves the head's
three motors for (A, B, z) by a fixed number of Newton steps on the inverse's own
closed form (finite-difference Jacobian, Cramer's rule), checks the residual, then
undoes the map by fixed-point steps.

Not in these programs: the real-axis tables (``tables export --format pmac``: the
controller's leadscrew and backlash tables act on the motors after the inverse),
the cyclic errors and the servo lag (motor effects the kinematics do not hold).
Numbers are written as plain decimals (no exponent), each the shortest text that
reads back as the same double; PMAC keeps them with a 36-bit mantissa (TUM
"Computational Features"), about 1e-11 relative.
"""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal

import numpy as np

from .. import __version__
from ..errormap import COMPONENTS, ErrorMap
from ..kinematics import BOW_REF_MM, Geometry
from ..profile import MOTORS, Profile

#: Run-time error bit of coordinate system 1 (TUM, forward-kinematic example)
ERROR_FLAG = "M5182"
ERROR_FLAG_DEF = "M5182->Y:$00203F,22,1"
#: The G43 tool length offset the kinematics add to the profile's tool [mm]
TOOL_OFFSET_Q = "Q100"
#: Newton steps of the forward solution, and the residual it must reach [mm]
FK_STEPS = 8
FK_TOL_MM = 1e-6
#: finite-difference steps of the forward's Jacobian [deg, deg, mm]
FK_H = 1e-4
#: fixed-point steps that undo the map in the forward
MAP_UNDO_STEPS = 3
#: virtual-axis variables in the map's order x, y, z, A, B (TUM: Q7, Q8, Q9, Q1, Q2)
AXIS_Q = ("Q7", "Q8", "Q9", "Q1", "Q2")


def k(x: float) -> str:
    """A constant as PMAC reads it: a plain decimal, negative ones in parentheses."""
    if x == 0.0:
        return "0"
    s = format(Decimal(repr(abs(float(x)))), "f")
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    return s if x > 0 else f"(-{s})"


def lin(terms: list[tuple[float, str]], const: float = 0.0) -> str:
    """Σ c·v + const, zero terms left out, signs as binary operators."""
    out = ""
    for c, v in terms:
        if c == 0.0:
            continue
        mag = "" if abs(c) == 1.0 else f"{k(abs(c))}*"
        out += ("-" if c < 0 else ("+" if out else "")) + mag + v
    if const != 0.0 or not out:
        out += ("-" if const < 0 else ("+" if out else "")) + k(abs(const))
    return out


class _Prog:
    """A kinematic program's lines and its work variables (Q20 and up)."""

    def __init__(self, first: int = 20) -> None:
        self.lines: list[str] = []
        self.vars: dict[str, str] = {}
        self.next = first

    def __getattr__(self, name: str) -> str:
        if name.startswith("_") or name in ("lines", "vars", "next"):
            raise AttributeError(name)
        return self.v(name)

    def v(self, name: str) -> str:
        if name not in self.vars:
            if f"Q{self.next}" == TOOL_OFFSET_Q:
                self.next += 1
            self.vars[name] = f"Q{self.next}"
            self.next += 1
        return self.vars[name]

    def __call__(self, *lines: str) -> None:
        self.lines.extend(lines)

    def let(self, name: str, expr: str) -> None:
        self.lines.append(f"{self.v(name)}={expr}")


@dataclass(frozen=True)
class KinematicsFile:
    """The download file: its text and how many work variables it uses."""

    text: str
    inverse_vars: int
    forward_vars: int
    #: the highest work variable either program uses (Q20 up to it)
    last_q: int


# ---------------------------------------------------------------- the map


def _map_block(p: _Prog, emap: ErrorMap, src: list[str], dst: list[str]) -> None:
    """dst = Q' = Q − e(Q) (Eq. 6, chain.correct_virtual); src, dst: variables of
    x, y, z, A, B."""
    exps, C = emap._plan
    deg = max(max(e) for e in exps) if exps else 0
    lo, hi = emap.lo, emap.hi
    span = np.where(hi > lo, hi - lo, 1.0)
    for v in range(5):
        if deg == 0 or not any(e[v] for e in exps):
            continue
        a = 2.0 / span[v]
        t = lin([(a, src[v])], -2.0 * lo[v] / span[v] - 1.0)
        p.let("mt", t)
        # clamp to [−1, 1] without a branch: (|t+1| − |t−1|)/2
        p.let(f"L{v}_1", f"(ABS({p.mt}+1)-ABS({p.mt}-1))/2")
        u = p.v(f"L{v}_1")
        top = max(e[v] for e in exps)
        for n in range(1, top):
            prev = "1" if n == 1 else p.v(f"L{v}_{n - 1}")
            # (n+1) P_{n+1} = (2n+1) u P_n − n P_{n−1}
            p.let(
                f"L{v}_{n + 1}",
                f"({k(2 * n + 1)}*{u}*{p.v(f'L{v}_{n}')}-{k(n)}*{prev})/{k(n + 1)}",
            )
    for i in range(5):
        p.let(f"e{i}", k(float(C[0, i])) if 0 in range(len(exps)) else "0")
    for uidx in range(1, len(exps)):
        factors = [p.v(f"L{v}_{n}") for v, n in enumerate(exps[uidx]) if n]
        p.let("mprod", "*".join(factors))
        for i in np.flatnonzero(C[uidx]).tolist():
            c = float(C[uidx, i])
            p.let(f"e{i}", f"{p.v(f'e{i}')}{'-' if c < 0 else '+'}{k(abs(c))}*{p.mprod}")
    for i in range(5):
        p(f"{dst[i]}={src[i]}-{p.v(f'e{i}')}")


# ---------------------------------------------------------------- the head


def _head(p: _Prog, geo: Geometry, a: str, b: str, z: str, clamp: bool) -> None:
    """Motor positions p_1..p_3 [mm] (variables ``ph1``..``ph3``) of the head for
    the tool pose A, B [deg] and work z [mm]: kinematics._solve and inverse, with
    the spin γ [deg] the root of K0 + Kc cos γ + Ks sin γ = 0 nearest zero.

    ``clamp``: out of reach is not an error here (the forward's Newton steps go
    through such points; its residual check judges); else it sets the flag
    ``bad``.
    """
    nul, Mp = geo._m
    p.let("ca", f"COS({a})")
    p.let("sa", f"SIN({a})")
    p.let("cb", f"COS({b})")
    p.let("sb", f"SIN({b})")
    p.let("sbsa", f"{p.sb}*{p.sa}")
    p.let("sbca", f"{p.sb}*{p.ca}")
    p.let("cbsa", f"{p.cb}*{p.sa}")
    p.let("cbca", f"{p.cb}*{p.ca}")
    gu = np.sum(geo.g * geo.u, axis=1)
    for i in range(3):
        ux, uy, uz = geo.u[i]
        bx, by, bz = geo.b[i]
        p.let(f"r0_{i}", lin([(ux, p.cb), (-uz, p.sb)]))
        p.let(f"r1_{i}", lin([(ux, p.sbsa), (uy, p.ca), (uz, p.cbsa)]))
        p.let(f"r2_{i}", lin([(ux, p.sbca), (-uy, p.sa), (uz, p.cbca)]))
        r0, r1, r2 = p.v(f"r0_{i}"), p.v(f"r1_{i}"), p.v(f"r2_{i}")
        p.let(f"kc0_{i}", lin([(-bz, r2)], float(gu[i])))
        p.let(f"kcc_{i}", lin([(-bx, r0), (-by, r1)]))
        p.let(f"kcs_{i}", lin([(-bx, r1), (by, r0)]))
    tx, ty, tz = geo.tool
    p.let("tz", f"{k(tz)}-{TOOL_OFFSET_Q}")
    # rows of Rab for the z component: (−sb, cb sa, cb ca)
    p.let("kz0", f"{lin([(1.0, z)], float(geo.origin[2]))}-{p.cbca}*{p.tz}")
    p.let("kzc", lin([(tx, p.sb), (-ty, p.cbsa)]))
    p.let("kzs", lin([(-tx, p.cbsa), (-ty, p.sb)]))
    for name, legs, zz in (("K0", "kc0", "kz0"), ("Kc", "kcc", "kzc"), ("Ks", "kcs", "kzs")):
        p.let(
            name,
            lin(
                [(float(nul[i]), p.v(f"{legs}_{i}")) for i in range(3)] + [(float(nul[3]), p.v(zz))]
            ),
        )
    _spin(p, clamp)
    for i in range(3):
        p.let(
            f"rl{i}",
            f"{p.v(f'kc0_{i}')}+{p.v(f'kcc_{i}')}*{p.cg}+{p.v(f'kcs_{i}')}*{p.sg}",
        )
    p.let("rlz", f"{p.kz0}+{p.kzc}*{p.cg}+{p.kzs}*{p.sg}")
    for j in range(3):
        p.let(
            f"c{j}",
            lin([(float(Mp[j, i]), p.v(f"rl{i}")) for i in range(3)] + [(float(Mp[j, 3]), p.rlz)]),
        )
    _struts(p, geo, clamp)


def _spin(p: _Prog, clamp: bool) -> None:
    """γ [deg] (``gam``, its cosine and sine ``cg``, ``sg``): of the two roots of
    K0 + Kc cos γ + Ks sin γ = 0, γ = φ ± acos(−K0 / ρ), the one nearest zero
    (kinematics._solve); ATAN2 takes its cosine argument from Q0."""
    p.let("rho", f"SQRT({p.Kc}*{p.Kc}+{p.Ks}*{p.Ks})")
    p(f"Q0={p.Kc}")
    p.let("phi", f"ATAN2({p.Ks})")
    p.let("cd", f"-{p.K0}/{p.rho}")
    p(f"IF (ABS({p.cd})>1)")
    if clamp:
        p.let("cd", f"{p.cd}/ABS({p.cd})")
    else:
        p.let("bad", "1")
        p.let("cd", f"{p.cd}/ABS({p.cd})")
    p("ENDIF")
    p.let("dl", f"ACOS({p.cd})")
    for g, sign in (("g1", "+"), ("g2", "-")):
        p.let(g, f"{p.phi}{sign}{p.dl}")
        gv = p.v(g)
        p(f"IF ({gv}>180)", f"{gv}={gv}-360", "ENDIF")
        p(f"IF ({gv}<-180)", f"{gv}={gv}+360", "ENDIF")
    p.let("gam", p.g1)
    p(f"IF (ABS({p.g2})<ABS({p.g1}))", f"{p.gam}={p.g2}", "ENDIF")
    p.let("cg", f"COS({p.gam})")
    p.let("sg", f"SIN({p.gam})")


def _struts(p: _Prog, geo: Geometry, clamp: bool) -> None:
    """p_i = d_i·v_i + sqrt((d_i·v_i)² − |v_i|² + L_i²), v_i = c + R b_i − g_i (the
    hinge above the ball joint), then the bowed guides' Newton steps."""
    for i in range(3):
        bx, by, bz = geo.b[i]
        _rotate(p, f"b{i}", float(bx), float(by), k(float(bz)))
        v = []
        for j in range(3):
            p.let(f"v{j}", f"{p.v(f'c{j}')}+{p.v(f'b{i}_{j}')}-{k(float(geo.g[i, j]))}")
            v.append(p.v(f"v{j}"))
        d = geo.d[i]
        p.let("dv", lin([(float(d[j]), v[j]) for j in range(3)]))
        p.let(
            "disc",
            f"{p.dv}*{p.dv}-{v[0]}*{v[0]}-{v[1]}*{v[1]}-{v[2]}*{v[2]}+{k(float(geo.L[i] ** 2))}",
        )
        p(f"IF ({p.disc}<0)")
        if not clamp:
            p.let("bad", "1")
        p.let("disc", "0")
        p("ENDIF")
        p.let(f"ph{i + 1}", f"{p.dv}+SQRT({p.disc})")
        if geo.guide_bow is not None:
            _bow(p, geo, i, v)


def _rotate(p: _Prog, name: str, wx: float, wy: float, wz: str) -> None:
    """``name_0..2`` = R w, R = Ry(B) Rx(A) Rz(γ) (kinematics._Solved.rotate); w_z
    a variable or constant text."""
    p.let("rx", lin([(wx, p.cg), (-wy, p.sg)]))
    p.let("ry", lin([(wx, p.sg), (wy, p.cg)]))
    p.let("ry2", f"{p.ca}*{p.ry}-{p.sa}*{wz}")
    p.let("rz2", f"{p.sa}*{p.ry}+{p.ca}*{wz}")
    p.let(f"{name}_0", f"{p.cb}*{p.rx}+{p.sb}*{p.rz2}")
    p.let(f"{name}_1", p.ry2)
    p.let(f"{name}_2", f"{p.cb}*{p.rz2}-{p.sb}*{p.rx}")


def _bow(p: _Prog, geo: Geometry, i: int, v: list[str]) -> None:
    """Newton on |v_i − a_i(P_i) + g_i|² = L_i², 6 steps (kinematics._bowed_guides)."""
    assert geo.guide_bow is not None
    bow = float(geo.guide_bow[i])
    d, rad = geo.d[i], geo.radial[i]
    ph = p.v(f"ph{i + 1}")
    p.let("bn", "0")
    p(f"WHILE ({p.bn}<6)")
    p.let("bq", f"{ph}*{ph}")
    w = []
    for j in range(3):
        # hinge offset: P d + bow (P/100)² r
        p.let(
            f"w{j}",
            f"{v[j]}-({lin([(float(d[j]), ph), (bow * float(rad[j]) / BOW_REF_MM**2, p.bq)])})",
        )
        w.append(p.v(f"w{j}"))
    for j in range(3):
        p.let(f"da{j}", lin([(2 * bow * float(rad[j]) / BOW_REF_MM**2, ph)], float(d[j])))
    p.let("bf", f"{w[0]}*{w[0]}+{w[1]}*{w[1]}+{w[2]}*{w[2]}-{k(float(geo.L[i] ** 2))}")
    p.let("bfp", f"-2*({w[0]}*{p.da0}+{w[1]}*{p.da1}+{w[2]}*{p.da2})")
    p.let(f"ph{i + 1}", f"{ph}-{p.bf}/{p.bfp}")
    p.let("bn", f"{p.bn}+1")
    p("ENDWHILE")


def _table_motors(p: _Prog, geo: Geometry, dx: str, dy: str) -> None:
    """p5, p6 from the table displacement (kinematics.table_motors)."""
    p.let("p6", f"{dy}/{k(1.0 + geo.scale_y)}")
    p.let("p5", f"({dx}-{k(geo.squareness)}*{p.p6})/{k(1.0 + geo.scale_x)}")
    if geo.table_straightness is not None:
        kx, ky = (float(x) for x in geo.table_straightness)
        p.let("tn", "0")
        p(f"WHILE ({p.tn}<4)")
        p.let("p6", f"({dy}-{k(kx / 1e6)}*{p.p5}*{p.p5})/{k(1.0 + geo.scale_y)}")
        p.let(
            "p5",
            f"({dx}-{k(geo.squareness)}*{p.p6}-{k(ky / 1e6)}*{p.p6}*{p.p6})/{k(1.0 + geo.scale_x)}",
        )
        p.let("tn", f"{p.tn}+1")
        p("ENDWHILE")


def _tool_xy(p: _Prog, geo: Geometry) -> None:
    """T − c = R t, components ``rt_0..2``."""
    tx, ty, _ = geo.tool
    _rotate(p, "rt", float(tx), float(ty), p.tz)


# ---------------------------------------------------------------- the programs


def inverse_program(geo: Geometry, emap: ErrorMap | None, cpm: list[float]) -> _Prog:
    """OPEN INVERSE: Q1, Q2, Q7–Q9 [deg, mm] → P1–P3, P5, P6 [counts]."""
    p = _Prog(20)
    p.let("bad", "0")
    if emap is not None:
        _map_block(p, emap, list(AXIS_Q), [p.v(f"q{i}") for i in range(5)])
    else:
        for i in range(5):
            p.let(f"q{i}", AXIS_Q[i])
    qx, qy, qz, qa, qb = (p.v(f"q{i}") for i in range(5))
    _head(p, geo, qa, qb, qz, clamp=False)
    _tool_xy(p, geo)
    p.let("dx", f"{lin([(1.0, qx)], float(geo.origin[0]))}-{p.c0}-{p.rt_0}")
    p.let("dy", f"{lin([(1.0, qy)], float(geo.origin[1]))}-{p.c1}-{p.rt_1}")
    _table_motors(p, geo, p.dx, p.dy)
    p(f"IF ({p.bad}>0)", f"{ERROR_FLAG}=1", "ELSE")
    for m, var, c in zip(MOTORS, ("ph1", "ph2", "ph3", "p5", "p6"), cpm, strict=True):
        p(f"P{m}={p.v(var)}*{k(c)}")
    p("ENDIF")
    return p


def _det3(m: list[list[str]]) -> str:
    return (
        f"{m[0][0]}*({m[1][1]}*{m[2][2]}-{m[1][2]}*{m[2][1]})"
        f"-{m[0][1]}*({m[1][0]}*{m[2][2]}-{m[1][2]}*{m[2][0]})"
        f"+{m[0][2]}*({m[1][0]}*{m[2][1]}-{m[1][1]}*{m[2][0]})"
    )


def _newton(p: _Prog, geo: Geometry, pm: list[str]) -> None:
    """FK_STEPS Newton steps on (A, B, z) [deg, deg, mm] (``xa``, ``xb``, ``xz``)
    for the head motors ``pm[0..2]`` [mm]: the inverse's head at x and at x + h
    along each unknown (J = (f_j − f_0) / h), the step by Cramer's rule."""
    p.let("nn", "0")
    p(f"WHILE ({p.nn}<{FK_STEPS})")
    p.let("jj", "0")
    p(f"WHILE ({p.jj}<4)")
    for name, var, j in (("ea", "xa", 1), ("eb", "xb", 2), ("ez", "xz", 3)):
        p.let(name, p.v(var))
        p(f"IF ({p.jj}={j})", f"{p.v(name)}={p.v(var)}+{k(FK_H)}", "ENDIF")
    _head(p, geo, p.ea, p.eb, p.ez, clamp=True)
    for j in range(4):
        p(f"IF ({p.jj}={j})")
        for i in range(3):
            p.let(f"f{j}_{i}", p.v(f"ph{i + 1}"))
        p("ENDIF")
    p.let("jj", f"{p.jj}+1")
    p("ENDWHILE")
    for i in range(3):
        for j in range(1, 4):
            p.let(f"J{i}{j}", f"({p.v(f'f{j}_{i}')}-{p.v(f'f0_{i}')})/{k(FK_H)}")
        p.let(f"rr{i}", f"{pm[i]}-{p.v(f'f0_{i}')}")
    J = [[p.v(f"J{i}{j}") for j in range(1, 4)] for i in range(3)]
    r = [p.v(f"rr{i}") for i in range(3)]
    p.let("det", _det3(J))
    p(f"IF ({p.det}!=0)")
    for col, var in enumerate(("xa", "xb", "xz")):
        cramer = [[r[i] if j == col else J[i][j] for j in range(3)] for i in range(3)]
        p.let(f"num{col}", _det3(cramer))
        p.let(var, f"{p.v(var)}+{p.v(f'num{col}')}/{p.det}")
    p("ENDIF")
    p.let("nn", f"{p.nn}+1")
    p("ENDWHILE")


def forward_program(geo: Geometry, emap: ErrorMap | None, cpm: list[float]) -> _Prog:
    """OPEN FORWARD: P1–P3, P5, P6 [counts] → Q1, Q2, Q7–Q9 [deg, mm]."""
    p = _Prog(20)
    for i, m in enumerate(MOTORS):
        p.let(f"pm{i}", f"P{m}/{k(cpm[i])}")
    pm = [p.v(f"pm{i}") for i in range(5)]
    # start: level platform, z from the mean slider travel
    p.let("xa", "0")
    p.let("xb", "0")
    p.let("xz", f"({pm[0]}+{pm[1]}+{pm[2]})/3")
    _newton(p, geo, pm)
    # the pose at the solution, and how far it misses the motors
    # (out of reach here is an error: a clamped root can fake a solution)
    p.let("bad", "0")
    _head(p, geo, p.xa, p.xb, p.xz, clamp=False)
    p.let("res", "0")
    for i in range(3):
        p.let("ri", f"ABS({pm[i]}-{p.v(f'ph{i + 1}')})")
        p(f"IF ({p.ri}>{p.res})", f"{p.res}={p.ri}", "ENDIF")
    _tool_xy(p, geo)
    # table displacement D(P5, P6) (kinematics.table_displacement)
    p.let("tdx", lin([(1.0 + geo.scale_x, pm[3]), (geo.squareness, pm[4])]))
    p.let("tdy", lin([(1.0 + geo.scale_y, pm[4])]))
    if geo.table_straightness is not None:
        kx, ky = (float(x) for x in geo.table_straightness)
        p.let("tdx", f"{p.tdx}+{k(ky / 1e6)}*{pm[4]}*{pm[4]}")
        p.let("tdy", f"{p.tdy}+{k(kx / 1e6)}*{pm[3]}*{pm[3]}")
    p.let("gq0", f"{p.c0}+{p.rt_0}+{lin([(1.0, p.tdx)], -float(geo.origin[0]))}")
    p.let("gq1", f"{p.c1}+{p.rt_1}+{lin([(1.0, p.tdy)], -float(geo.origin[1]))}")
    p.let("gq2", p.xz)
    p.let("gq3", p.xa)
    p.let("gq4", p.xb)
    geo_q = [p.v(f"gq{i}") for i in range(5)]
    if emap is not None:
        # Q with Q − e(Q) = the geometry's pose: Q ← Q + (pose − Q'(Q))
        for i in range(5):
            p.let(f"u{i}", geo_q[i])
        p.let("un", "0")
        p(f"WHILE ({p.un}<{MAP_UNDO_STEPS})")
        _map_block(p, emap, [p.v(f"u{i}") for i in range(5)], [p.v(f"w{i}") for i in range(5)])
        for i in range(5):
            p.let(f"u{i}", f"{p.v(f'u{i}')}+{geo_q[i]}-{p.v(f'w{i}')}")
        p.let("un", f"{p.un}+1")
        p("ENDWHILE")
        out = [p.v(f"u{i}") for i in range(5)]
    else:
        out = geo_q
    p(f"IF ({p.res}>{k(FK_TOL_MM)} OR {p.bad}>0)", f"{ERROR_FLAG}=1", "ELSE")
    for q, var in zip(AXIS_Q, out, strict=True):
        p(f"{q}={var}")
    p("ENDIF")
    return p


def export(profile: Profile, source: str = "") -> KinematicsFile:
    """The download file for ``profile`` (module docstring)."""
    from .. import errormap

    geo = Geometry.from_params(profile.kinematics, profile.origin, profile.table, profile.effects)
    emap = errormap.from_profile(profile)
    cpm = [float(profile.motor(m).counts_per_mm) for m in MOTORS]
    inv = inverse_program(geo, emap, cpm)
    fwd = forward_program(geo, emap, cpm)
    period = float(profile.period_ms)
    head = _header(profile, source, emap, geo, period, inv, fwd)
    motors = " ".join(f"#{m}->I" for m in MOTORS)
    lines = [
        *head,
        "CLOSE",
        "I15=0",
        "&1",
        motors,
        ERROR_FLAG_DEF,
        f"{TOOL_OFFSET_Q}=0",
        f"I5113={k(period)}",
        "OPEN FORWARD",
        "CLEAR",
        *fwd.lines,
        "CLOSE",
        "OPEN INVERSE",
        "CLEAR",
        *inv.lines,
        "CLOSE",
        "I5150=1",
    ]
    return KinematicsFile(
        "\n".join(lines) + "\n", len(inv.vars), len(fwd.vars), max(inv.next, fwd.next) - 1
    )


def _header(
    profile: Profile,
    source: str,
    emap: ErrorMap | None,
    geo: Geometry,
    period: float,
    inv: _Prog,
    fwd: _Prog,
) -> list[str]:
    kept = ["the calibrated [kinematics] (legs, tool) and [table] (scales, squareness)"]
    if geo.guide_bow is not None:
        kept.append("effects.guide_bow (6 Newton steps a leg)")
    if geo.table_straightness is not None:
        kept.append("effects.table_straightness (4 fixed-point steps)")
    if emap is not None:
        comps = ", ".join(c for c in COMPONENTS if c in emap.coef)
        kept.append(f"the virtual-axis map of Eq. 4-6 ({comps}; Q' = Q - e(Q))")
    hi = max(inv.next, fwd.next) - 1
    text = [
        f"prsxy-post {__version__}: embedded kinematics for Turbo PMAC coordinate system 1",
        f"profile: {profile.name} ({source or profile.source})",
        "Holds: " + "; ".join(kept) + ".",
        "Every term is written exactly as the project computes it (the map as its",
        "  Legendre polynomials, no lookup table); pmacparser runs these programs to",
        "  1e-9 count of the project's chain (tests/test_writers_pmac_kinematics.py).",
        "Not here: the real-axis tables. Download `prsxy-post tables export --format pmac`",
        "  first (leadscrew and backlash tables act on the motors after the inverse),",
        "  then this file; the cyclic errors and servo lag are motor effects outside",
        "  the kinematics.",
        "Settings (Software Reference, I-variables; User Manual, Kinematic Calculations):",
        "  I15=0: SIN, COS, ACOS, ATAN2 in degrees (global: every program of the card)",
        "  #1->I ... #6->I: motors 1, 2, 3, 5, 6 are inverse-kinematic axes; the inverse",
        "    puts their positions in P1-P3, P5, P6, in counts ("
        + ", ".join(f"{profile.motor(m).counts_per_mm:g}" for m in MOTORS)
        + " counts/mm)",
        f"  I5113={period:g}: segmentation time Isx13 of C.S. 1 [ms], the coarse period:",
        "    moves are cut into segments this long, the inverse runs at each segment's",
        "    end and the motors are splined between",
        "  I5150=1: Isx50, kinematic calculations on (set last, after both programs)",
        f"  {ERROR_FLAG_DEF}: C.S. 1 run-time error bit; both programs set it",
        "    when a pose is out of reach or the forward solution does not converge",
        f"  {TOOL_OFFSET_Q}: the G43 tool length offset [mm] added to the profile's tool;",
        '    after changing it, PMATCH (in a program: DWELL0 CMD"PMATCH" DWELL0)',
        f"  work variables Q20-Q{hi} of C.S. 1; P1-P32, Q0-Q10 as the manual reserves them",
        "  I11=0 (the default): the forward's iterations take as long as they need",
        "    (User Manual, Iterative Solutions)",
        f"Forward: {FK_STEPS} Newton steps on the head's three motors for A, B, z, then",
        f"  the residual must be under {FK_TOL_MM:g} mm; {MAP_UNDO_STEPS} fixed-point steps undo",
        "  the map.",
    ]
    return ["; " + x for x in text]


__all__ = ["KinematicsFile", "export", "forward_program", "inverse_program", "k", "lin"]
