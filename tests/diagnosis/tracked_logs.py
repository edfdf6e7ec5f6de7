"""Logs of a joint tracking a reference under a PID loop on a jittered lossy logger, from the
independent simulator, and the verdict row the tests read off them; the library's effects as
that simulator writes them, sized to the joint."""

from bench.analysis import analyze_record
from independent_joint import independent_record
from tests.diagnosis.test_conditions import _within
from tests.diagnosis.test_independent_records import _travel


def library_physics(spec, kind: str) -> dict:
    """``kind`` of the effect library in the independent simulator's conventions (its
    ``physics``), relative to the joint's Coulomb level and travel."""
    Fc, tr = spec.friction.Fc, _travel(spec)
    return {"gravity": dict(mgl=0.1 * Fc, q0=0.7),
            "cogging": dict(detent=0.06 * Fc, detent_pitch=tr / 6, detent_h2=0.4),
            "position_dependent_friction": dict(ripple=0.1, ripple_pitch=tr / 3.0),
            "direction_asymmetry": dict(asym=0.12), "torque_offset": dict(constant=0.2 * Fc),
            "thermal_drift": dict(warm=0.3, warm_tau=15.0), "torque_lag": dict(lag=0.004)}[kind]


def tracked_row(spec, seed: int, reference, felt: bool, physics=None) -> tuple:
    """(joint, seed, physics, effects named, flagged, within 5 %, parameter errors) of a log of
    ``spec`` tracking ``reference`` (positions per ms) under a 6 Hz PID; ``felt``: a 1 % Fc
    disturbance the record does not hold, else 2 % Fc reading noise."""
    f = spec.friction
    noise = dict(disturbance=0.01 * f.Fc) if felt else dict(torque_noise=0.02 * f.Fc)
    rec, _ = independent_record(spec, duration=len(reference) * 1e-3, seed=seed, pd=(6.0, 0.0, 1.5),
                                reference=reference, jitter=0.3, drop=0.005, physics=physics, **noise)
    doc = analyze_record(rec).report()
    return (spec.name, seed, physics, [d["effect"] for d in doc["diagnosis"] if d["significant"]],
            doc["unexplained"]["structured"], _within(doc, spec),
            {k: round(doc["parameters"][k] / getattr(f, k) - 1, 3) for k in ("Fc", "Fs", "sigma2")})
