"""Comments that speak: ``(MSG,…)``, ``(DEBUG,…)``, ``(PRINT,…)``, ``(ABORT,…)``
as LinuxCNC's ``convert_comment`` treats them.

The library never prints: a message goes to
:attr:`~.config.InterpreterConfig.on_message` (the command line writes it to
standard error). ``DEBUG`` and ``PRINT`` substitute parameters the way
``convert_param_comment`` does: ``#12`` and ``#<name>`` become their values
(``%lf``, six decimals), ``%d`` switches to no decimals, ``%f`` to four and
``%.Nf`` to N (0–9) for the parameters after it; an unknown one, or one 29
characters do not hold, prints ``######``. ``DEBUG`` speaks only while #5599
is positive. ``ABORT`` stops the program with its text as the error. ``LOG``,
``LOGOPEN``, ``LOGAPPEND`` and ``LOGCLOSE`` (files LinuxCNC writes on the
controller) are ignored, as any other comment.
"""

from __future__ import annotations

from collections.abc import Callable


def expand(
    text: str, number: Callable[[int], float | None], named: Callable[[str], float | None]
) -> str:
    """``convert_param_comment``: parameters in a DEBUG/PRINT text replaced by values."""
    out: list[str] = []
    fmt = "%lf"
    i = 0
    n = len(text)
    while i < n:
        c = text[i]
        if c == "%":
            i += 1
            d = text[i] if i < n else ""
            if d == "d":
                fmt = "%.0f"
                i += 1
            elif d == "f":
                fmt = "%.4f"
                i += 1
            elif d == ".":
                if (
                    i + 2 < n + 1
                    and i + 1 < n
                    and text[i + 1].isdigit()
                    and i + 2 < n
                    and text[i + 2] == "f"
                ):
                    fmt = f"%.{text[i + 1]}f"
                    i += 3
                else:
                    out.append("%.")  # not a format: LinuxCNC keeps the characters
                    i += 1
            else:
                out.append("%")
            continue
        if c == "#":
            i += 1
            value: float | None = None
            if i < n and text[i].isdigit():
                j = i
                while j < n and text[j].isdigit():
                    j += 1
                value = number(int(text[i:j]))
                i = j
            elif i < n and text[i] == "<":
                j = text.find(">", i)
                if j < 0:
                    out.append("######")
                    break
                name = "".join(ch.lower() for ch in text[i + 1 : j] if not ch.isspace())
                value = named(name)
                i = j + 1
            else:
                out.append("#")
                continue
            if value is None:
                out.append("######")
            else:
                v = 0.0 if abs(value) < 0.0001 else value  # LinuxCNC's equal(value, 0.0)
                shown = fmt.replace("lf", "f") % v
                # LinuxCNC formats into a buffer of 30 characters (VAL_LEN)
                out.append(shown if len(shown) < 30 else "######")
            continue
        out.append(c)
        i += 1
    return "".join(out)


def kind_of(comment: str) -> tuple[str, str] | None:
    """(kind, text) of a comment that speaks, None for an ordinary one."""
    stripped = comment.lstrip()
    low = stripped.lower()
    for kind in ("msg,", "debug,", "print,", "abort,"):
        if low.startswith(kind):
            return kind[:-1].upper(), stripped[len(kind) :]
    return None
