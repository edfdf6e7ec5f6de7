"""Which named gears the wider-band probe still questions (bench.wide_band.gear_settled): the
numbers are the fits the diagnosis made of j2 records (independent simulator)."""
from types import SimpleNamespace

import pytest

from bench.wide_band import gear_settled
from virtual_drives.presets import PRESETS

LUGRE = {"Fc": PRESETS["j2"].friction.Fc, "Fs": PRESETS["j2"].friction.Fs}
# a spring with 37 % of the friction beyond it, told as play (tuning seed 1664)
SPRING_AS_PLAY = {"bl_width": 5.7e-5, "bl_load": 15.7, "bl_kappa": 0.0227, "bl_contact": 24.95}
# a true backlash with 60 % of the friction beyond it (fresh seed 5638)
TRUE_PLAY = {"bl_width": 2.0e-3, "bl_load": 109.1, "bl_kappa": 0.0055, "bl_contact": 60.3}


def _diag(names, values):
    model = SimpleNamespace(names=lambda: list(names), values=dict(LUGRE, **values))
    return SimpleNamespace(model=model)


@pytest.mark.parametrize("names,values,settled", [
    ([], {}, False),                                              # no gear: probe
    (["cogging"], {}, False),
    (["joint_flexibility"], {"flex_frequency": 11.0}, True),      # a spring seen in the band
    (["backlash"], dict(TRUE_PLAY, bl_kappa=0.0), True),          # no friction beyond
    (["backlash"], TRUE_PLAY, True),                              # play far wider than its wind-up
    (["backlash"], SPRING_AS_PLAY, False),                        # play inside its contact's wind-up
    (["inertia_error", "backlash"], TRUE_PLAY, False),            # beside what a spring passes for
    (["gravity", "backlash"], TRUE_PLAY, False),
    (["inertia_error", "backlash"], dict(TRUE_PLAY, bl_kappa=0.0), True),
    (["backlash"], {k: v for k, v in TRUE_PLAY.items() if k != "bl_contact"}, True),  # the default contact
])
def test_which_named_gears_the_wider_band_still_questions(names, values, settled):
    assert gear_settled(_diag(names, values)) is settled


def test_the_widened_warning_says_where_the_named_resonance_lies():
    """Above the default band it bent LuGre unseen; near its edge (the probe searches from 0.8x
    the band, and the wider fit may settle below it) the warning must not say "above"."""
    from bench.wide_band import widened_warning
    assert "lies above the default comparison band (10 Hz" in widened_warning(10.0, 30.0, 14.5)
    near = widened_warning(12.0, 36.0, 9.68)
    assert "above" not in near and "named at 9.68 Hz only at a band wider" in near and "36 Hz" in near


def test_a_spring_refitted_into_a_low_pass_or_out_of_its_band_fails_at_the_end():
    """``JointFlexibility.fails_at_end``: the final values must still describe a resonance that
    rings, inside the band the record shows (twice the excitation up to the comparison cutoff)."""
    from bench.effects.joint_flexibility import MAX_DAMPING, JointFlexibility
    flex = JointFlexibility()
    ctx = SimpleNamespace(data=SimpleNamespace(c=SimpleNamespace(frequency=0.5, cutoff=20.0)))
    assert flex.fails_at_end({"flex_damping": 0.05, "flex_frequency": 9.5}, ctx) == ""
    assert flex.fails_at_end({"flex_damping": MAX_DAMPING, "flex_frequency": 9.5}, ctx) == ""
    assert "0.83" in flex.fails_at_end({"flex_damping": 0.83, "flex_frequency": 14.8}, ctx)
    assert "0.6 Hz" in flex.fails_at_end({"flex_damping": 0.05, "flex_frequency": 0.6}, ctx)
    assert "25 Hz" in flex.fails_at_end({"flex_damping": 0.05, "flex_frequency": 25.0}, ctx)
