"""Is a residual structured, whatever the noise?  Predictability on held-out motion segments.

A residual left by missing physics is a function of the joint's state and history: where the
joint is (q), how it moves (v, direction), how far it has travelled since the last reversal
(presliding, backlash, hysteresis), and slow time (drift).  Noise is not, wherever it enters:
on the torque reading, on the encoder, or as a disturbance torque the joint feels but the
record never contained (process noise, white or coloured).  So instead of modelling the noise
(a floor from fourth differences sees only what is on the recorded signals), ask whether a
flexible learner on those state signals, trained on some motion segments, predicts the
residual on the others clearly better than chance.  Segments run between velocity reversals
and are dealt into interleaved folds (``bench.screening.CrossValidation``), so noise that is
correlated over less than a segment cannot leak from training to scoring.

The learner is scikit-learn's histogram gradient boosting (interactions, no scaling, fast on a
few thousand samples).  Acceleration and the recorded torque are deliberately *not* inputs: the
residual is built from them (tau - M q''), and a disturbance torque shows up in q'' (and, in
closed loop, in the controller's torque), so a learner given them would "predict" process
noise.  The signals the learner relies on (drop-one refits) point to the physics.  A change of
the friction level over the record, which the coarse time signal misses, is tested apart
(``bench.level_drift``) and reported under ``level``.
"""
from __future__ import annotations

import math

import numpy as np

from bench.checkpoint import checkpoint
from bench.level_drift import bias, level_change
from bench.rest_memory import rest_memory
from bench.residual_stats import binned_r2, paired_t

# Held-out fraction of residual variance the learner must predict, and the consistency of its
# gain across held-out segments (paired t), for "structured".  Measured on tuning seeds
# (1000-1999) with tools/tune_noise_floor.py: clean joints under white, coloured and 1/f
# process noise, reading noise, coarse encoders, 2 kHz, closed loop and two tones predicted
# -0.4 to +0.2 of their residual (the +0.2 at 0.5 % of Fc or less), library effects before
# they were added 0.76-0.91, a saturating torque constant left after the diagnosis 0.57-0.88.
MIN_PREDICTED = 0.10
T_CRIT = 3.0
MAX_SAMPLES = 3000        # the residual is low-passed: more samples add cost, not information
FEATURES = ("position", "velocity", "direction", "travel_since_reversal", "time")
# One repeated excitation ties the motion signals together: under a single sine, position and
# direction give the phase, hence the velocity and the travel since the last reversal, so the
# learner's choice among them is arbitrary (a local friction defect along the travel was told
# as "the travel since the last reversal and the velocity").  A signal is tied to another when
# that other (with the direction) determines it: binned R^2 >= TIED, as the torque is tied to
# the position in ``bench.effects.periodic.torque_locked``.  Measured 2026-11-29 on
# tuning seeds 1960-1965, six joints, our generator: one sine, clean and under coloured
# process noise, 0.979-1.0 for every pair that a phase determines; two tones, PD tracking
# and robot joint logs at most 0.92 (the rotary motor's two tones), mostly 0.6-0.85.
TIED = 0.95
MOTION = ("position", "velocity", "travel_since_reversal")


def _since_reversal(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """|q - q at the last velocity reversal|: the travel a presliding spring, a dead zone or a
    hysteresis loop remembers."""
    s = np.sign(v)
    s[s == 0] = 1.0
    rev = np.concatenate(([0], np.nonzero(s[1:] != s[:-1])[0] + 1))
    last = np.zeros(len(q), dtype=int)
    last[rev] = rev
    last = np.maximum.accumulate(last)
    return np.abs(q - q[last])


def features(c, idx: np.ndarray) -> dict[str, np.ndarray]:
    travel = _since_reversal(c.q, c.v)
    return {"position": c.q[idx], "velocity": c.v[idx], "direction": np.sign(c.v[idx]),
            "travel_since_reversal": travel[idx],
            # slow time only (a drift): a fine time axis would let noise that is correlated over
            # seconds leak from neighbouring segments
            "time": np.round((c.t[idx] - c.t[0]) / max(c.t[-1] - c.t[0], 1e-12) * 4.0)}


def ties(feats: dict) -> dict[str, list[str]]:
    """For each motion signal, the other motion signals that determine it on this record
    (``TIED``): whatever the residual follows through it, they could carry as well."""
    side = feats["direction"] > 0
    return {s: [o for o in MOTION if o != s and binned_r2(feats[s], feats[o], side) >= TIED]
            for s in MOTION}


def _held_out(X: np.ndarray, r: np.ndarray, fold: np.ndarray, n_folds: int):
    """Predictions of r on each fold by a learner fitted on the others, and the learners."""
    from sklearn.ensemble import HistGradientBoostingRegressor
    pred = np.zeros_like(r)
    models = []
    for k in range(n_folds):
        checkpoint()      # each learner takes ~1 s: a stopped analysis stops here too
        test = fold == k
        if not test.any() or test.all():
            models.append(None)
            continue
        m = HistGradientBoostingRegressor(max_iter=40, learning_rate=0.1, max_leaf_nodes=8,
                                          min_samples_leaf=max(20, len(r) // 40),
                                          l2_regularization=1.0, random_state=0)
        m.fit(X[~test], r[~test])
        pred[test] = m.predict(X[test])
        models.append(m)
    return pred, models


def _score(r, pred, fold, block, n_folds):
    """Held-out fraction of variance predicted, and the paired t of the gain over blocks."""
    base = np.empty_like(r)
    for k in range(n_folds):  # chance: the training folds' mean
        test = fold == k
        base[test] = r[~test].mean() if (~test).any() else 0.0
    e0, e1 = (r - base) ** 2, (r - pred) ** 2
    predicted = 1.0 - e1.sum() / max(e0.sum(), 1e-300)
    nb = int(block.max()) + 1
    counts = np.bincount(block, minlength=nb).astype(float)
    keep = counts > 0
    d = (np.bincount(block, e0 - e1, minlength=nb)[keep]) / counts[keep]
    t = paired_t(d) if len(d) > 2 else 0.0
    return float(predicted), t


def assess_predictability(c, residual: np.ndarray, cv, explain: bool = True) -> dict:
    """Held-out predictability of ``residual`` (on the comparison grid) from the state
    signals, on the folds of ``cv``.  ``explain``: when structured, which signals it needs
    (held-out permutation importance: how much of the prediction is lost when one signal is
    shuffled within the scored fold)."""
    stride = max(1, len(cv.idx) // MAX_SAMPLES)
    idx, fold, block = cv.idx[::stride], cv.fold[::stride], cv.block[::stride]
    r = residual[idx]
    scale = float(np.std(r)) or 1.0
    r = r / scale
    feats = features(c, idx)
    X = np.column_stack([feats[k] for k in FEATURES])
    pred, models = _held_out(X, r, fold, cv.n_folds)
    predicted, t = _score(r, pred, fold, block, cv.n_folds)
    scored = np.zeros(len(residual), dtype=bool)
    scored[cv.idx] = True
    out = {"predicted_fraction": predicted, "t": t,
           "structured_rms": scale * math.sqrt(max(predicted, 0.0)), "relies_on": [],
           "importance": {}, "level": level_change(c, residual, scored), "bias": bias(c, residual, scored),
           "rest": rest_memory(c, residual, scored), "tied": {}}
    if explain and predicted > 0:
        out["tied"] = ties(feats)
        rng = np.random.default_rng(0)
        for j, name in enumerate(FEATURES):
            p = pred.copy()
            for k, m in enumerate(models):
                test = fold == k
                if m is None or not test.any():
                    continue
                Xp = X[test].copy()
                Xp[:, j] = rng.permutation(Xp[:, j])
                p[test] = m.predict(Xp)
            out["importance"][name] = predicted - _score(r, p, fold, block, cv.n_folds)[0]
        # a signal is relied on when shuffling it loses a fifth of what was predicted
        out["relies_on"] = [k for k, d in sorted(out["importance"].items(), key=lambda kv: -kv[1])
                            if d >= 0.2 * predicted]
    return out
