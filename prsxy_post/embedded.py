"""The paper's embedded route from the command line's side: a G-code program as
the Cartesian Turbo PMAC program that runs through the calibrated kinematics the
controller holds (:mod:`prsxy_post.writers.pmac_kinematics` writes those,
:mod:`prsxy_post.writers.pmac_cartesian` the moves, blended where Turbo PMAC's
blend stays within the path tolerance at the profile's Isx13)."""

from __future__ import annotations

from .chain import check_motions
from .errors import LimitError
from .gcode import iter_motions, split_lines
from .profile import Profile
from .program import interpreter_config
from .writers.base import Provenance
from .writers.pmac_cartesian import write_program


def program_text(text: str, source: str, profile: Profile, prov: Provenance) -> str:
    """Interpret G-code ``text`` (file name ``source`` for errors) under the profile's
    interpreter settings and write it as the Cartesian program; the first problem
    the program itself shows (a feed above the machine's) is raised."""
    motions = list(iter_motions(split_lines(text), interpreter_config(profile), source))
    problems = check_motions(motions, profile)
    if problems:
        raise problems[0].located(source)
    if not motions:
        raise LimitError(f"{source}: the program makes no motion", expected="a G-code program")
    return write_program(motions, profile, prov, motions[0].start)
