"""Expressions as LinuxCNC evaluates them: operators, precedence, functions.

An expression read from a line (:mod:`.read`) is compiled once into a closure
``f(params) -> float``; a line executed again (a loop, a subroutine) reuses it.
The arithmetic is LinuxCNC's (``interp_execute.cc``: ``execute_binary1/2``,
``execute_unary``), not Python's where they differ:

- binary operators in six levels, all left-associative (``2**3**2`` is 64):
  ``**`` > ``* / MOD`` > ``+ -`` > ``EQ NE GT GE LT LE`` > ``AND OR XOR``;
- a leading sign binds tighter than any binary operator (``[-2**2]`` is 4);
- ``MOD`` is C's ``fmod`` made non-negative by adding ``|b|``;
- ``EQ`` and ``NE`` compare within 0.0001 (``TOLERANCE_EQUAL``); ``GT``,
  ``GE``, ``LT``, ``LE`` exactly (LinuxCNC 2.9; later versions give GE and LE
  the tolerance too);
- ``AND``, ``OR``, ``XOR`` give 1.0 or 0.0, any non-zero being true;
- angles are degrees; SIN, COS and TAN work in C's long double
  (``sin(x * M_PIl / 180.0)`` picks ``sinl`` in C++), the inverse functions
  convert their double result with ``(r * 180.0) / M_PIl``, as LinuxCNC does, so
  that ``SIN[30]`` and ``TAN[9143008]`` are to the bit what they are there;
- ``ROUND`` is C's ``(int)(x ± 0.5)``: 32-bit, half away from zero;
  ``FIX``/``FUP`` are C's floor/ceil (a zero result keeps the argument's
  sign); ``ATAN[y]/[x]`` is atan2 in degrees;
- a value that comes out NaN or infinite is an error where it is read (every
  bracketed expression, function and parameter value), not later.

Errors are :class:`ExprError` with the column of the offending operand; the
reader turns them into located :class:`~prsxy_post.errors.GCodeError` s.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

import numpy as np

#: LinuxCNC's TOLERANCE_EQUAL (interp_internal.hh)
TOLERANCE_EQUAL = 0.0001

_PI_L = np.longdouble("3.14159265358979323846264338327950288")
_L180 = np.longdouble(180.0)


class ExprError(Exception):
    """An expression that cannot be evaluated; ``column`` is 1-based in the line."""

    def __init__(self, message: str, column: int, expected: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.column = column
        self.expected = expected


class Params(Protocol):
    """What an expression reads: parameters by number and by name."""

    def get(self, index: int, column: int) -> float: ...

    def get_named(self, name: str, column: int) -> float: ...

    def exists_named(self, name: str) -> bool: ...


Value = Callable[[Params], float]


def to_radians(deg: float) -> float:
    """``deg * M_PIl / 180.0`` in long double, rounded to double (LinuxCNC's SIN/COS/TAN)."""
    return float(np.longdouble(deg) * _PI_L / _L180)


def to_degrees(rad: float) -> float:
    """``(rad * 180.0) / M_PIl``, rounded to double (ASIN/ACOS/ATAN): the product
    of two doubles is a double, the division by M_PIl is in long double."""
    return float(np.longdouble(rad * 180.0) / _PI_L)


def c_pow(a: float, b: float) -> float:
    """C's ``pow`` (inf on overflow, inf for 0 to a negative power), for the
    operands LinuxCNC lets through (a negative base needs an integer exponent)."""
    try:
        return math.pow(a, b)
    except OverflowError:
        if a < 0 and b == math.floor(b) and math.fmod(b, 2.0) != 0:
            return -math.inf
        return math.inf
    except ValueError:  # 0 ** negative
        if b == math.floor(b) and math.fmod(b, 2.0) != 0 and math.copysign(1.0, a) < 0:
            return -math.inf
        return math.inf


def c_round(x: float) -> float:
    """``(double)(int)(x + (x < 0 ? -0.5 : 0.5))``: a 32-bit int; out of its range
    x86's conversion gives INT_MIN."""
    t = math.trunc(x + (-0.5 if x < 0.0 else 0.5))
    if not -2147483648 <= t <= 2147483647:
        return -2147483648.0
    return float(t)


def c_floor(x: float) -> float:
    """C's ``floor``: a zero result keeps the argument's sign (``floor(-0.0)`` is
    -0.0), which Python's int-valued ``math.floor`` loses; ATAN's quadrant sees it."""
    r = math.floor(x)
    return float(r) if r else math.copysign(0.0, x)


def c_ceil(x: float) -> float:
    """C's ``ceil``: ``ceil(-0.25)`` is -0.0 (a zero result keeps the argument's
    sign), so ``ATAN[FUP[-0.25]]/[-1]`` is -180 in LinuxCNC."""
    r = math.ceil(x)
    return float(r) if r else math.copysign(0.0, x)


# ---------------------------------------------------------------- binary operators

#: precedence per operator name, as LinuxCNC's ``precedence()``
PRECEDENCE = {
    "and": 2,
    "or": 2,
    "xor": 2,
    "eq": 3,
    "ne": 3,
    "gt": 3,
    "ge": 3,
    "lt": 3,
    "le": 3,
    "+": 4,
    "-": 4,
    "*": 5,
    "/": 5,
    "mod": 5,
    "**": 6,
}


def binary(op: str, left: Value, right: Value, column: int) -> Value:
    """The closure of ``left op right``; ``column`` is the operator's (for / by 0)."""
    if op == "+":
        return lambda p: left(p) + right(p)
    if op == "-":
        return lambda p: left(p) - right(p)
    if op == "*":
        return lambda p: left(p) * right(p)
    if op == "/":

        def div(p: Params) -> float:
            a = left(p)
            b = right(p)
            if b == 0.0:
                raise ExprError("division by zero", column, "a divisor other than 0")
            return a / b

        return div
    if op == "mod":

        def mod(p: Params) -> float:
            a = left(p)
            b = right(p)
            if b == 0.0:
                return math.nan  # C's fmod(a, 0); the value's check reports it
            r = math.fmod(a, b)
            return r + abs(b) if r < 0.0 else r

        return mod
    if op == "**":

        def power(p: Params) -> float:
            a = left(p)
            b = right(p)
            if a < 0.0 and math.floor(b) != b:
                raise ExprError(
                    "a negative number raised to a non-integer power",
                    column,
                    "an integer exponent for a negative base",
                )
            return c_pow(a, b)

        return power
    if op == "and":
        return lambda p: 0.0 if (left(p) == 0.0) | (right(p) == 0.0) else 1.0
    if op == "or":
        return lambda p: 1.0 if (left(p) != 0.0) | (right(p) != 0.0) else 0.0
    if op == "xor":
        return lambda p: 1.0 if (left(p) != 0.0) != (right(p) != 0.0) else 0.0
    if op == "eq":
        return lambda p: 1.0 if abs(left(p) - right(p)) < TOLERANCE_EQUAL else 0.0
    if op == "ne":
        return lambda p: 1.0 if abs(left(p) - right(p)) >= TOLERANCE_EQUAL else 0.0
    if op == "gt":
        return lambda p: 1.0 if left(p) > right(p) else 0.0
    if op == "lt":
        return lambda p: 1.0 if left(p) < right(p) else 0.0
    if op == "ge":
        return lambda p: 1.0 if left(p) >= right(p) else 0.0
    if op == "le":
        return lambda p: 1.0 if left(p) <= right(p) else 0.0
    raise AssertionError(op)


# ---------------------------------------------------------------- functions

FUNCTIONS = (
    "abs",
    "acos",
    "asin",
    "atan",
    "cos",
    "exists",
    "exp",
    "fix",
    "fup",
    "ln",
    "round",
    "sin",
    "sqrt",
    "tan",
)


def unary(name: str, arg: Value, column: int) -> Value:
    """The closure of ``NAME[arg]`` (not ATAN, not EXISTS: see :func:`atan`)."""
    if name == "abs":

        def absolute(p: Params) -> float:
            # LinuxCNC's execute_unary negates only a value below 0.0, so ABS[-0]
            # stays -0 (which ATAN's quadrant then sees: ATAN[0]/[ABS[-0]] = 180)
            x = arg(p)
            return -x if x < 0.0 else x

        return absolute
    if name in ("acos", "asin"):
        f = math.acos if name == "acos" else math.asin

        def inverse(p: Params) -> float:
            x = arg(p)
            if x < -1.0 or x > 1.0:
                raise ExprError(
                    f"{name.upper()} of {x:g} is undefined", column, "an argument from -1 to 1"
                )
            return to_degrees(f(x))

        return inverse
    if name in ("cos", "sin", "tan"):
        # C++'s <cmath> picks the long double overload for a long double
        # argument: sinl(x * M_PIl / 180), then rounded to double
        g = {"cos": np.cos, "sin": np.sin, "tan": np.tan}[name]
        return lambda p: float(g(np.longdouble(arg(p)) * _PI_L / _L180))
    if name == "exp":

        def exp(p: Params) -> float:
            try:
                return math.exp(arg(p))
            except OverflowError:
                return math.inf

        return exp
    if name == "fix":
        return lambda p: c_floor(arg(p))
    if name == "fup":
        return lambda p: c_ceil(arg(p))
    if name == "ln":

        def ln(p: Params) -> float:
            x = arg(p)
            if x <= 0.0:
                raise ExprError(f"LN of {x:g} is undefined", column, "a positive argument")
            return math.log(x)

        return ln
    if name == "round":
        return lambda p: c_round(arg(p))
    if name == "sqrt":

        def sqrt(p: Params) -> float:
            x = arg(p)
            if x < 0.0:
                raise ExprError(f"SQRT of {x:g} is undefined", column, "an argument of 0 or more")
            return math.sqrt(x)

        return sqrt
    raise AssertionError(name)


def atan(y: Value, x: Value) -> Value:
    """``ATAN[y]/[x]``: atan2 in degrees, from -180 to 180."""
    return lambda p: to_degrees(math.atan2(y(p), x(p)))


def finite(value: Value, column: int) -> Value:
    """A value checked where LinuxCNC reads it (``read_real_value``)."""

    def checked(p: Params) -> float:
        v = value(p)
        if v - v != 0.0:  # NaN or ±inf
            what = "not a number" if v != v else "infinity"
            raise ExprError(f"the calculation gives {what}", column, "a value the machine can use")
        return v

    return checked


def constant(v: float) -> Value:
    return lambda p: v


def negate(value: Value) -> Value:
    return lambda p: -value(p)
