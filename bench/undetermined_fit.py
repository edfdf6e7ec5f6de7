"""A structured residual left by a fit the record does not determine is not told as missing
physics.

On a coarse logger the torque can be mostly inertia (the rotary stage at 124 Hz: M q'' 25x
the friction), and the fit then runs off (Fc 300x, Fs 1e4x the truth, every value "not
identifiable") and leaves a residual the state learner predicts well: the verdict pointed at
non-linear viscous friction, position effects and backlash, none of which the joint had.  When
none of the three values a friction compensator needs (Fc, Fs, sigma2) is identifiable, the
verdict says so first and what to record instead; its own findings follow, kept, since some
physics (a gear's play) can itself leave the fit undetermined.
"""
from __future__ import annotations

NEEDED = ("Fc", "Fs", "sigma2")


def told(doc: dict, rate_hz: float, cutoff_hz: float) -> bool:
    """Put the undetermined fit first in ``doc["unexplained"]`` when it is structured and none
    of ``NEEDED`` is identifiable; whether it was."""
    left = doc.get("unexplained") or {}
    ident = doc.get("identifiable") or {}
    if not left.get("structured") or any(ident.get(k) for k in NEEDED):
        left["fit_undetermined"] = False
        return False
    hint = (f"a record that determines the model first: a finer logger (this one samples at {rate_hz:.3g} Hz "
            f"and the analysis keeps {cutoff_hz:.3g} Hz of it), a longer record, or an excitation that "
            f"holds the joint sliding for longer at a lower acceleration")
    left["fit_undetermined"] = True
    left["look_for"] = [hint] + [x for x in left.get("look_for", []) if x != hint]
    left["evidence"] = (f"the record does not determine the LuGre model (Fc, Fs and sigma2 are none of them "
                        f"identifiable), so the structure left may be the fit's rather than physics missing "
                        f"from the library; look for {hint}.  Taken as it is: {left.get('evidence', '')}")
    return True
