"""Issue 13, "a loop that closes": calibration and diagnosis on a machine with effects
outside the contract, judged by executing the converted programs.

The machine has random errors in every contract term, real-axis tables with
backlash, bowed guides, curved table axes and cyclic errors on two motors
(``tests/loop.py``). It is measured (0.5 µm ballbar, 1 µm poses, 0.3 µm laser)
while commanded with the nominal profile; the library calibrates from the
contract's files (tables, kinematic parameters, the library's physical effects,
then the virtual-axis map on what remains); ``diagnose -o`` runs on that profile
with the same data. Each profile converts the sample programs; the written PMAC
program is read back and executed by the machine (servo, play model, forward
kinematics of the true geometry) and every executed point is held against the
point the chain meant on the G-code path. Judged at the points: how the controller
moves between them is the conversion's business (tests/test_tracking.py).
"""

from __future__ import annotations

import pytest

from prsxy_post import profile as profile_mod

from . import loop


@pytest.mark.slow
def test_the_loop_closes_within_1_um(nominal: profile_mod.Profile) -> None:
    truth = loop.unmodelled_machine(nominal, 7)
    data = loop.measurements(truth, nominal, 7)
    for program in loop.PROGRAMS:
        assert loop.trace_error(truth, nominal, program) > 0.1, program
    cal = loop.calibrated(nominal, data)
    for program in loop.PROGRAMS:
        err = loop.trace_error(truth, cal, program)
        assert err < 1.0e-3, f"calibrated: {program} {err * 1000:.3f} µm"
    # diagnose -o on the calibrated profile, written and read back as a file
    upd, d = loop.diagnosed(cal, nominal, data)
    upd = profile_mod.loads(profile_mod.dumps(upd.raw), "diagnosed.toml")
    for program in loop.PROGRAMS:
        err = loop.trace_error(truth, upd, program)
        assert err < 1.0e-3, f"diagnosed: {program} {err * 1000:.3f} µm ({d.summary})"
