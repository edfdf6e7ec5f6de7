"""A friction-velocity map read and analysed end to end (``bench.friction_map``,
``bench.map_fit``, ``bench.map_analysis``): maps as a lab makes them from the independent
simulator's PID velocity sweeps (``tests.map_records``), fresh seeds 10261-10270 (tuning was on
20000-20025), joints and noise the thresholds were not chosen on among them."""
import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bench.analysis import analyze_record
from bench.readers import read_record
from tests.map_records import swept_map, write_map
from virtual_drives.presets import PRESETS


def _bench(*args):
    return subprocess.run([sys.executable, "-m", "bench.cli", *map(str, args)], capture_output=True, text=True)


def _doc(path, **kw):
    return analyze_record(read_record(path, **kw), name=str(path)).report()


def test_a_clean_map_in_degrees_is_identified_with_nothing_named_or_left(tmp_path):
    spec = PRESETS["j2"]
    v, F = swept_map(spec, 10261, felt=False)
    path = tmp_path / "j2_map.csv"
    write_map(path, np.degrees(v), F, header=("speed [deg/s]", "friction torque [N*m]"))
    out = tmp_path / "res.csv"
    r = _bench("analyze", path, "--json", tmp_path / "doc.json", "--residuals", out)
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "doc.json").read_text())
    assert doc["record"] == "friction_map" and doc["input"]["points"] == len(v)
    assert doc["units"]["conversions"]["velocity"]["from"] == "deg/s"
    f = spec.friction
    for k in ("Fc", "Fs", "sigma2"):
        assert abs(doc["parameters"][k] / getattr(f, k) - 1) < 0.02, (k, doc["parameters"])
        assert doc["identifiable"][k]
    assert not [d for d in doc["diagnosis"] if d["significant"]], doc["diagnosis"]
    assert not doc["unexplained"]["structured"], doc["unexplained"]
    assert set(doc["not_identified"]) == {"sigma0", "sigma1"}
    table = np.genfromtxt(out, delimiter=",", names=True)
    assert table.dtype.names == ("velocity", "measured", "baseline", "final", "held_out")
    assert np.allclose(table["measured"], F) and np.allclose(table["velocity"], v, rtol=1e-6)


@pytest.mark.parametrize("joint, seed, physics, effect", [
    ("j1", 10262, dict(constant=0.2), "torque_offset"),
    ("linear", 10263, dict(asym=0.12), "direction_asymmetry"),
    ("j3", 10264, dict(stribeck_delta=2.0), "stribeck_shape"),
    ("rotary", 10265, dict(constant=-0.15), "torque_offset"),
])
def test_a_library_effect_on_a_map_is_named_and_nothing_is_left(tmp_path, joint, seed, physics, effect):
    spec = PRESETS[joint]
    f = spec.friction
    physics = {k: (val * f.Fc if k == "constant" else val) for k, val in physics.items()}
    v, F = swept_map(spec, seed, physics=physics, felt=seed % 2 == 0)
    path = tmp_path / "map.csv"
    write_map(path, v, F, header=("v", "tau"))
    doc = _doc(path, columns="qd=v,tau=tau", joint_type="prismatic" if joint == "linear" else None)
    named = [d["effect"] for d in doc["diagnosis"] if d["significant"]]
    assert named[:1] == [effect], doc["diagnosis"]
    assert not doc["unexplained"]["structured"], doc["unexplained"]
    # the simulator scales the negative levels by 1 + asym: its mean level is Fc (1 + asym / 2)
    level = f.Fc * (1 + physics.get("asym", 0.0) / 2)
    assert abs(doc["parameters"]["Fc"] / level - 1) < 0.03, doc["parameters"]


def test_a_map_with_a_breakaway_peak_above_rest_is_unexplained_and_nothing_credited(tmp_path):
    """Simscape's Rotational Friction block written as a map (its own formula, not this
    project's model): the friction rises from a Coulomb level at rest to a breakaway peak,
    which no LuGre map does."""
    wrong = 0
    for seed in range(10266, 10271):
        rng = np.random.default_rng(seed)
        Fc = rng.uniform(1, 100)
        Fs, vb = Fc * rng.uniform(1.2, 1.6), rng.uniform(0.01, 0.1)
        speeds = np.geomspace(0.1 * vb, 20 * vb, 12)
        v = np.concatenate([speeds, -speeds])
        a = np.abs(v)
        F = np.sign(v) * (np.sqrt(2 * np.e) * (Fs - Fc) * np.exp(-(a / (vb * np.sqrt(2))) ** 2) * a / (vb * np.sqrt(2))
                          + Fc * np.tanh(10 * a / vb)) + rng.uniform(0.2, 1.0) * Fc / (20 * vb) * v
        F += rng.normal(0.0, 0.002 * Fc, len(v))
        path = tmp_path / f"map{seed}.csv"
        write_map(path, v, F)
        doc = _doc(path)
        wrong += bool([d for d in doc["diagnosis"] if d["significant"]]) or not doc["unexplained"]["structured"]
    assert wrong == 0


def test_map_input_errors_are_one_line(tmp_path):
    t = np.arange(4000) * 1e-3
    trace = tmp_path / "trace.csv"       # samples in time with their times left out
    write_map(trace, np.cos(2 * np.pi * t), np.sign(np.cos(2 * np.pi * t)) * 2.0 + np.cos(2 * np.pi * t))
    r = _bench("analyze", trace)
    assert r.returncode == 2 and "--sample-rate" in r.stderr and "Traceback" not in r.stderr, r.stderr
    timed = tmp_path / "timed.csv"       # a log with its time, the time left out of the mapping
    np.savetxt(timed, np.column_stack([t, np.cos(2 * np.pi * t), np.sign(np.cos(2 * np.pi * t))]), delimiter=",",
               header="time,velocity,torque", comments="")
    r = _bench("analyze", timed, "--columns", "qd=velocity,tau=torque")
    assert r.returncode == 2 and "no time column mapped" in r.stderr, r.stderr
    spec = PRESETS["j4"]
    v, F = swept_map(spec, 10261, felt=True)
    path = tmp_path / "m.csv"
    write_map(path, v, F)
    r = _bench("analyze", path, "--columns", "qd=speed,tau=torque")
    assert r.returncode == 2 and "no column 'speed' (for qd)" in r.stderr and "velocity [rad/s]" in r.stderr, r.stderr
    r = _bench("analyze", path, "--add", "cogging")
    assert r.returncode == 2 and "friction-velocity map" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    one_way = tmp_path / "one.csv"
    write_map(one_way, v[v > 0], F[v > 0])
    doc = _doc(one_way)
    assert any("one direction only" in w for w in doc["warnings"])
    assert not [d for d in doc["diagnosis"] if d["effect"] in ("torque_offset", "direction_asymmetry")]
    few = tmp_path / "few.csv"
    write_map(few, v[:5], F[:5])
    r = _bench("analyze", few)
    assert r.returncode == 2 and "at least" in r.stderr, r.stderr
    huge = tmp_path / "huge.csv"
    write_map(huge, v, F * 1e300)
    r = _bench("analyze", huge)
    assert r.returncode == 2 and "unit mistake" in r.stderr and "Traceback" not in r.stderr, r.stderr
    empty = tmp_path / "empty.csv"
    write_map(empty, v, F * np.nan)
    r = _bench("analyze", empty)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Warning" not in r.stderr, r.stderr


def _root_viscous_map(seed):
    rng = np.random.default_rng(seed)
    Fc = rng.uniform(1, 100)
    Fs, vs = Fc * rng.uniform(1.1, 1.6), rng.uniform(0.01, 0.1)
    beta, c = rng.uniform(0.4, 0.6), rng.uniform(0.5, 1.5) * Fc
    speeds = np.geomspace(0.2 * vs, 10 * vs, 12)
    v = np.concatenate([speeds, -speeds])
    F = np.sign(v) * (Fc + (Fs - Fc) * np.exp(-np.abs(v) / vs) + c * (np.abs(v) / (10 * vs)) ** beta)
    return v, F + rng.normal(0.0, 0.002 * Fc, len(v)), Fc


def test_the_speed_spread_keeps_a_bent_maps_fc_from_being_claimed(tmp_path):
    """Where the verdict misses |v|^0.5 viscous friction, the values' move between the slower
    and the faster speeds (``speed_spread``, joined to the standard errors) keeps Fc from being
    reported identifiable on at least half the maps where the noise's errors alone claimed it.
    Tuning seeds 20040-20059: 7 claimed by the noise's errors, 2 after; the bar was set from
    those.  (Fresh seeds 10280-10319, before this test: 22 and 7 of 40.)"""
    from bench.friction_map import build
    from bench.map_analysis import analyze_map
    from bench.identify import is_identifiable
    by_noise = claimed = 0
    for seed in range(10320, 10340):
        v, F, _ = _root_viscous_map(seed)
        a = analyze_map(build(v, F, {"qd": None, "tau": None}, {"qd": "v", "tau": "F"}, {}, {}, "map", "csv"))
        doc = a.report()
        missed = not doc["unexplained"]["structured"]
        by_noise += missed and is_identifiable(a.final.values["Fc"], a.final.stderr()["Fc"])
        claimed += missed and doc["identifiable"]["Fc"]
        assert doc["speed_spread"]["Fc"] >= 0 and doc["uncertainty"]["Fc"] >= a.final.stderr()["Fc"]
    assert by_noise > 0 and claimed <= by_noise / 2, (by_noise, claimed)


@pytest.mark.xfail(strict=True, reason="README known limits: on a map, viscous friction like |v|^0.5 is "
                   "mostly absorbed by LuGre or a Stribeck exponent (fresh seeds: 1 of 6 flagged, 3 credited)")
def test_viscous_friction_growing_like_a_root_of_the_speed_is_not_told_as_a_library_effect(tmp_path):
    """Viscous friction ~ |v|^beta (beta 0.4-0.6) beside a Stribeck dip, written by its own
    formula: LuGre bends to it (Fc 20-50 % high with well under 1 % of Fc left on interleaved
    speeds).  Tuning seeds 20010-20015: flagged 5 of 6 by the rising-map rule or the shape
    across speeds, nothing credited.  These fresh seeds: flagged 1 of 6, a Stribeck exponent
    (1.2-1.9) credited on 3 with nothing left -- it did not carry over, so this stays a known
    limit, and the test says what should hold."""
    credited = flagged = 0
    for seed in range(10272, 10278):
        v, F, _ = _root_viscous_map(seed)
        path = tmp_path / f"root{seed}.csv"
        write_map(path, v, F)
        doc = _doc(path)
        credited += bool([d for d in doc["diagnosis"] if d["significant"]])
        flagged += doc["unexplained"]["structured"]
    assert credited == 0 and flagged >= 4, (credited, flagged)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(-1e5, 1e5, allow_nan=False), st.floats(-1e11, 1e11, allow_nan=False)),
                min_size=8, max_size=40))
def test_any_table_of_speeds_and_torques_is_refused_in_one_line_or_answered_in_strict_json(rows):
    from bench.errors import BenchError
    from bench.friction_map import build
    from bench.map_analysis import analyze_map
    v, F = (np.array(c, dtype=float) for c in zip(*rows))
    try:
        doc = analyze_map(build(v, F, {"qd": None, "tau": None}, {"qd": "v", "tau": "F"}, {}, {}, "m", "csv")).report()
    except BenchError as e:
        assert "\n" not in str(e)
        return
    json.dumps(doc, allow_nan=False)
    assert all(np.isfinite(x) for x in doc["parameters"].values())


def test_a_map_of_means_beside_their_spread_and_a_map_of_motor_current(tmp_path):
    """Labs write a map's points as means beside their spread ("torque_mean, torque_std, n"):
    the mean is the friction, the spread names no role.  A map of motor current has no column
    named as a torque: the refusal asks for that mapping (not for a time column, which it was),
    and mapped with the torque constant it is read in N*m.  Fresh seeds 10346, 10347."""
    spec = PRESETS["j3"]
    f = spec.friction
    v, F = swept_map(spec, 10346, felt=True)
    spread = np.full(len(v), 0.01 * f.Fc)
    means = tmp_path / "means.csv"
    np.savetxt(means, np.column_stack([v, F, spread, np.full(len(v), 4000)]), delimiter=",",
               header="velocity [rad/s],Mean torque [N*m],torque_std [N*m],n", comments="")
    doc = _doc(means)
    assert doc["record"] == "friction_map" and doc["input"]["columns"]["tau"] == "Mean torque [N*m]", doc["input"]
    assert abs(doc["parameters"]["Fc"] / f.Fc - 1) < 0.03, doc["parameters"]
    spec = PRESETS["rotary"]
    v, F = swept_map(spec, 10347, felt=False)
    current = tmp_path / "current.csv"
    np.savetxt(current, np.column_stack([v, F / 0.08]), delimiter=",", header="velocity [rad/s],current [A]",
               comments="")
    r = _bench("analyze", current)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "--columns qd=velocity,tau=NAME" in r.stderr and "--torque-unit K*N*m" in r.stderr, r.stderr
    doc = _doc(current, columns="qd=velocity,tau=current", torque_unit="0.08*N*m")
    assert abs(doc["parameters"]["Fc"] / spec.friction.Fc - 1) < 0.03, doc["parameters"]


def test_a_map_of_several_joints_is_told_its_joints_and_read_one_by_one(tmp_path):
    """An arm's maps in one table, a velocity and a friction per joint ("dq2, tau_J2") or one
    velocity beside each joint's friction: read without --joint each is told its joints (they
    were asked for a time column, or told no torque was named); with it, that joint's map."""
    from bench.lugre import LuGreParams
    rng = np.random.default_rng(10362)
    speeds = np.geomspace(0.02, 2.0, 10)
    v = np.concatenate([speeds, -speeds])
    truth = {j: LuGreParams(2.0 * j, 2.6 * j, 8.0, 0.0, 0.0, 0.5 * j) for j in (1, 2, 3)}
    F = {j: p.steady_state(v) + rng.normal(0.0, 0.01, len(v)) for j, p in truth.items()}
    pairs = tmp_path / "pairs.csv"
    np.savetxt(pairs, np.column_stack([x for j in truth for x in (v, F[j])]), delimiter=",", comments="",
               header=",".join(f"dq{j},tau_J{j}" for j in truth))
    shared = tmp_path / "shared.csv"
    np.savetxt(shared, np.column_stack([v, *F.values()]), delimiter=",", comments="",
               header="velocity," + ",".join(f"friction_joint{j}" for j in truth))
    for path, words in ((pairs, "qd=NAME,tau=NAME"), (shared, "beside one velocity")):
        r = _bench("analyze", path)
        assert r.returncode == 2 and "several joints" in r.stderr and "(1, 2, 3)" in r.stderr, r.stderr
        assert words in r.stderr and "--joint N" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
        for j in (2, 3):
            doc = _doc(path, joint=str(j))
            assert doc["record"] == "friction_map"
            assert doc["parameters"]["Fc"] == pytest.approx(truth[j].Fc, rel=0.02), (path.name, j, doc["parameters"])
