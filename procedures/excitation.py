"""Excitation search (Section III): find a sine torque that makes one joint slide, by trials.

tau = tau_m sin(w t - pi/2) - k_c (q - centre) + g(q) on the tested joint while the others
hold; by default (``waveform = "two_level"``) the same sine at tau_m and ratio x tau_m on
alternate cycles (``procedures.waveforms``: it breaks the cycle lock; everything below is
about its peak amplitude tau_m).  Starting at the negative peak centres the motion; the
weak centring spring k_c (5 % of the amplitude at the window edge) corrects slow drift.
The record keeps the *total* applied torque (drive-reported) minus the host gravity model,
so identification sees exactly what was applied.

Each trial is judged model-free on its friction-velocity map F = tau - M a:
  moved       the joint broke away at all;
  sliding     it slides for most of the cycle, friction follows sgn(v) on the high-speed
              branch, and that branch is a straight line (slopes of its lower and upper halves
              agree), i.e. the Stribeck decay has died out there (alpha|v| >> 1);
  viscous     the branch's slope is positive, well determined and rises visibly.
The amplitude starts gentle and grows (doubling while stuck, then aiming at a target speed
with the line fitted on the last trial); frequency is the lowest that keeps the predicted
excursion inside the window.  Live, a trial stops and brakes before the predicted stopping
point leaves the window or the speed nears its limit; the next trial backs off.  Every trial
is kept with the reason it was accepted or rejected.  A joint that cannot slide inside its
workspace (or torque) ends with that reason.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy import signal

from bench.records import Record
from procedures.events import Emitter
from procedures.rig import Rig
from procedures.waveforms import check as check_waveform
from procedures.waveforms import label, unit_torque


@dataclass
class SearchSettings:
    margin_fraction: float = 0.05     # soft window inset from each limit, of the range
    excursion_fraction: float = 0.8   # share of the window a planned trial may sweep
    velocity_target: float = 0.8      # aimed peak speed, of the velocity limit
    velocity_abort: float = 0.95      # live abort, of the velocity limit
    torque_fraction: float = 0.9      # amplitude cap, of the torque headroom
    start_fraction: float = 0.05      # first amplitude, of the cap
    max_period: float = 4.0           # s: slowest trial (time budget)
    max_frequency: float = 3.0        # Hz: above this inertia dominates the map
    cycles: float = 3.0               # cycles per trial
    ramp_cycles: float = 0.05
    centring: float = 0.05
    max_trials: int = 14
    levels: tuple = (1.0,)            # extra velocity levels relative to the accepted one (Fig. 8)
    # procedures.waveforms: "sine", or "two_level" (every second cycle at level_ratio of the
    # amplitude) to break the cycle lock; the amplitude and the workspace check are the peak's.
    # two_level by default: on the tuning seeds it was diagnosed at least as well as the sine
    # on every hidden effect, with fewer wrong effects credited (tools/excitation_table.py,
    # README); 0.6 keeps the small cycles sliding both ways on the presets and test joints
    waveform: str = "two_level"
    level_ratio: float = 0.6


@dataclass
class Trial:
    index: int
    amplitude: float
    frequency: float
    outcome: str = "rejected"         # accepted | rejected | level
    reason: str = ""
    metrics: dict = field(default_factory=dict)


@dataclass
class ExcitationResult:
    joint: str
    ok: bool
    reason: str
    amplitude: float = float("nan")
    frequency: float = float("nan")
    record: Record | None = None
    trials: list[Trial] = field(default_factory=list)
    levels: list[dict] = field(default_factory=list)   # {level, amplitude, frequency, record, metrics}
    waveform: str = "two_level 0.6"

    def summary(self) -> dict:
        return {"joint": self.joint, "ok": self.ok, "reason": self.reason, "amplitude": self.amplitude,
                "frequency": self.frequency, "waveform": self.waveform, "trials": [asdict(t) for t in self.trials],
                "levels": [{k: v for k, v in lv.items() if k != "record"} for lv in self.levels]}


def search(rig: Rig, jid: str, settings: SearchSettings | None = None,
           emit: Emitter | None = None) -> ExcitationResult:
    st = settings or SearchSettings()
    check_waveform(st.waveform, st.level_ratio)
    j = rig.joints[jid]
    lo, hi = j["position_limits"]
    margin = st.margin_fraction * (hi - lo)
    window = (lo + margin, hi - margin)
    centre = 0.5 * (lo + hi)
    rig.move_to(jid, centre)
    M = rig.inertia(jid)
    vlim = j["velocity_limit"]
    cap = st.torque_fraction * (j["torque_limit"] - math.hypot(*j["gravity"])) / (1 + st.centring)
    v_target = st.velocity_target * vlim
    sweep = st.excursion_fraction * (window[1] - window[0])
    f_min, f_max = 1.0 / st.max_period, st.max_frequency

    def freq_for(v):  # sine velocity v sin(wt) sweeps 2 v / w peak to peak
        return float(np.clip(2.0 * v / sweep / (2 * math.pi), f_min, f_max))

    res = ExcitationResult(joint=jid, ok=False, reason="", waveform=label(st.waveform, st.level_ratio))
    A, f = st.start_fraction * cap, freq_for(v_target)
    A_bad = math.inf          # smallest amplitude that left the window / overspeeded at this f
    A_ok = 0.0                # largest amplitude that completed a trial inside the window
    best: tuple[Trial, Record] | None = None
    for n in range(st.max_trials):
        trial = Trial(n, float(A), float(f))
        data = _run_trial(rig, jid, A, f, centre, window, st)
        rec = _to_record(data, rig, jid, M, st)
        trial.metrics = m = _map_metrics(data, M, f, rig.dt, j)
        res.trials.append(trial)
        nxt_A, nxt_f = A, f
        if data["aborted"] in ("workspace", "velocity"):
            trial.reason = (f"stopped: predicted stop at {data['stop_at']:.4g} outside window "
                            f"[{window[0]:.4g}, {window[1]:.4g}]" if data["aborted"] == "workspace"
                            else f"stopped: speed {m['v_peak']:.4g} near the limit {vlim:.4g}")
            if data["aborted"] == "workspace" and f < f_max * 0.999:
                nxt_f = min(f * 1.4, f_max)          # same speed, less travel
            else:
                A_bad = min(A_bad, A)
                if A_ok > 0 and A_bad < 1.15 * A_ok:
                    _emit(emit, jid, trial)
                    break  # bracketed: nothing between what stays inside and what leaves
                nxt_A = math.sqrt(A_ok * A_bad) if A_ok > 0 else A * 0.8
        elif not m["moved"]:
            A_ok = max(A_ok, A)
            trial.reason = "stuck: the joint did not break away"
            nxt_A = 2.0 * A
        else:
            A_ok = max(A_ok, A)
            ok, why = _judge(m)
            fast_enough = m["v_peak"] >= 0.85 * v_target
            if ok:
                best = (trial, rec)
            if ok and (fast_enough or A >= 0.99 * min(cap, A_bad * 0.85)):
                trial.outcome, trial.reason = "accepted", "sliding with a linear viscous branch" + (
                    "" if fast_enough else f" (speed {m['v_peak']:.3g} < target {v_target:.3g}: amplitude capped)")
                res.ok, res.amplitude, res.frequency, res.record = True, A, f, rec
                _emit(emit, jid, trial)
                break
            trial.reason = (f"sliding, below target speed ({m['v_peak']:.3g} < {v_target:.3g})" if ok
                            else f"not yet sliding: {why}")
            v_next = v_target
            nxt_A = _amplitude_for(v_next, m, M, f) or 1.5 * A
            nxt_A = float(np.clip(nxt_A, 1.15 * A, 2.0 * A))
            # keep the predicted travel inside the window
            travel = m["excursion"] * (v_next / max(m["v_peak"], 1e-12)) * (f / freq_for(v_next))
            # frequency never comes down: less travel per cycle is always the safe side
            nxt_f = max(f, freq_for(v_next)) if travel <= sweep else min(f_max, f * travel / sweep)
        _emit(emit, jid, trial)
        nxt_A = min(nxt_A, cap, 0.95 * A_bad if not data["aborted"] else nxt_A)
        if nxt_A <= A * 1.02 and not data["aborted"] and nxt_f == f:
            break  # cannot grow any further
        A, f = nxt_A, nxt_f
    if not res.ok and best is not None:
        trial, rec = best
        trial.outcome = "accepted"
        trial.reason += "; accepted as the best sliding trial within the limits"
        res.ok, res.amplitude, res.frequency, res.record = True, trial.amplitude, trial.frequency, rec
        _emit(emit, jid, trial)
    if not res.ok:
        res.reason = _failure_reason(res.trials, cap, A_bad, window)
        return res
    res.reason = "accepted"
    res.levels.append({"level": 1.0, "amplitude": res.amplitude, "frequency": res.frequency,
                       "record": res.record, "metrics": _accepted(res).metrics})
    for level in st.levels:
        if abs(level - 1.0) > 1e-9:
            res.levels.append(_extra_level(rig, jid, level, res, M, centre, window, st, emit, freq_for))
    return res


def _accepted(res: ExcitationResult) -> Trial:
    return next(t for t in res.trials if t.outcome == "accepted")


def _extra_level(rig, jid, level, res, M, centre, window, st, emit, freq_for) -> dict:
    m0 = _accepted(res).metrics
    v = level * m0["v_peak"]
    f = max(freq_for(v), 1.0 / st.max_period)
    A = _amplitude_for(v, m0, M, f) or level * res.amplitude
    data = _run_trial(rig, jid, A, f, centre, window, st)
    m = _map_metrics(data, M, f, rig.dt, rig.joints[jid])
    ok, why = (False, f"stopped ({data['aborted']})") if data["aborted"] else _judge(m)
    t = Trial(len(res.trials), float(A), float(f), "level",
              f"velocity level {level:g}: " + ("sliding" if ok else why), m)
    res.trials.append(t)
    _emit(emit, jid, t)
    return {"level": level, "amplitude": A, "frequency": f, "sliding": ok, "metrics": m,
            "record": None if data["aborted"] else _to_record(data, rig, jid, M, st)}


def _failure_reason(trials: list[Trial], cap: float, A_bad: float, window) -> str:
    moved = [t for t in trials if t.metrics.get("moved") and not t.metrics.get("aborted")]
    if not moved:
        return (f"cannot reach sliding: the joint did not break away up to amplitude "
                f"{max(t.amplitude for t in trials):.4g} (cap {cap:.4g}, set by the torque limit)")
    if math.isfinite(A_bad):
        return (f"cannot reach sliding inside the workspace [{window[0]:.4g}, {window[1]:.4g}]: "
                f"amplitude {A_bad:.4g} already leaves it at {trials[-1].frequency:.3g} Hz, "
                f"and smaller amplitudes do not slide ({moved[-1].reason})")
    return f"cannot reach sliding within {len(trials)} trials ({trials[-1].reason})"


def _emit(emit: Emitter | None, jid: str, t: Trial) -> None:
    if emit is not None:
        emit.event("trial", joint=jid, **asdict(t))


def _smoothstep(x: float) -> float:
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


def _run_trial(rig: Rig, jid: str, A: float, f: float, centre: float, window, st: SearchSettings) -> dict:
    j = rig.joints[jid]
    dt = rig.dt
    n = int(round(st.cycles / f / dt))
    k_c = st.centring * A / max(0.5 * (window[1] - window[0]), 1e-12)
    stuck_check = int(round(0.6 / f / dt))
    moved_eps = _moved_threshold(j)
    vmax = st.velocity_abort * j["velocity_limit"]
    t, tau, q, v = (np.empty(n) for _ in range(4))
    aborted, stop_at, i = "", float("nan"), 0
    rig.segment = f"{jid}:trial A={A:.4g} f={f:.4g}"
    qmin = qmax = rig.samples[jid].position
    for i in range(n):
        s = rig.samples[jid]
        qi, vi = s.position, s.velocity
        if abs(vi) > vmax:
            aborted = "velocity"
            break
        stop = rig.stopping_point(jid, qi, vi)
        if not window[0] <= stop <= window[1]:
            aborted, stop_at = "workspace", stop
            break
        g = rig.gravity(jid, qi)
        cmd = A * _smoothstep(i * dt * f / st.ramp_cycles) * unit_torque(i * dt * f, st.waveform, st.level_ratio)
        new = rig.step({jid: cmd - k_c * (qi - centre) + g})
        t[i], tau[i], q[i], v[i] = i * dt, new[jid].torque - g, qi, vi
        qmin, qmax = min(qmin, qi), max(qmax, qi)
        if i == stuck_check and qmax - qmin < moved_eps:
            aborted = "stuck"
            i += 1
            break
    else:
        i = n
    if aborted in ("workspace", "velocity"):
        rig.brake_all()
    rig.segment = ""
    rig.settle()
    if abs(rig.samples[jid].position - centre) > 0.02 * (window[1] - window[0]):
        rig.move_to(jid, centre)
    return {"t": t[:i], "tau": tau[:i], "q": q[:i], "v": v[:i], "aborted": aborted, "stop_at": stop_at,
            "cycles_run": i * dt * f}


def _moved_threshold(j: dict) -> float:
    cpu = j.get("counts_per_unit")
    lo, hi = j["position_limits"]
    # beyond presliding (bristle) deflection: a few counts and 0.3 % of the range
    return max(50.0 / cpu if cpu else 0.0, 3e-3 * (hi - lo))


def _to_record(data: dict, rig: Rig, jid: str, M: float, st: SearchSettings) -> Record | None:
    if data["aborted"] or len(data["t"]) < 10:
        return None
    j = rig.joints[jid]
    revolute = j.get("joint_type", "revolute")
    meta = {"inertia": M, "joint_type": revolute, "position_unit": "rad" if revolute == "revolute" else "m",
            "torque_unit": "N*m" if revolute == "revolute" else "N", "joint": jid, "source": "bench",
            "waveform": label(st.waveform, st.level_ratio)}
    return Record(t=data["t"].copy(), tau=data["tau"].copy(), q=data["q"].copy(), meta=meta)


def _map_metrics(data: dict, M: float, f: float, dt: float, j: dict) -> dict:
    """Model-free description of a trial's friction-velocity map."""
    q, v, tau = data["q"], data["v"], data["tau"]
    out = {"cycles_run": data["cycles_run"], "aborted": data["aborted"] or None,
           "v_peak": float(np.max(np.abs(v))) if len(v) else 0.0,
           "excursion": float(np.ptp(q)) if len(q) else 0.0,
           "moved": bool(len(q) and np.ptp(q) >= _moved_threshold(j))}
    skip = int(round(0.5 / f / dt))
    if data["aborted"] or len(v) - skip < 50 or not out["moved"]:
        return out
    fc = float(np.clip(20.0 * f, 2.0, 0.05 / dt))
    sos = signal.butter(2, fc, fs=1.0 / dt, output="sos")
    vs = signal.sosfiltfilt(sos, v)
    F = signal.sosfiltfilt(sos, tau) - M * np.gradient(vs, dt)
    vs, F, q = vs[skip:], F[skip:], q[skip:]
    speed = np.abs(vs)
    vpk = float(np.percentile(speed, 99.5))
    out.update(v_peak=vpk, excursion=float(np.ptp(q)), sliding_fraction=float(np.mean(speed > 0.2 * vpk)))
    hi = speed >= 0.5 * vpk
    x, y = speed[hi], F[hi] * np.sign(vs[hi])
    if hi.sum() < 20:
        return out
    (s, c), cov = np.polyfit(x, y, 1, cov=True)
    resid = y - (c + s * x)
    lower = x < 0.75 * vpk
    s_lo = np.polyfit(x[lower], y[lower], 1)[0] if lower.sum() > 10 else s
    s_hi = np.polyfit(x[~lower], y[~lower], 1)[0] if (~lower).sum() > 10 else s
    out.update(coulomb_level=float(c), viscous_slope=float(s),
               slope_tstat=float(s / math.sqrt(max(cov[0, 0], 1e-300))),
               curvature=float(abs(s_hi - s_lo) / max(abs(s), 1e-300)),
               residual=float(np.sqrt(np.mean(resid ** 2)) / max(float(np.mean(np.abs(y))), 1e-300)),
               sign_agreement=float(np.mean(np.sign(F[hi]) == np.sign(vs[hi]))),
               viscous_rise=float(s * 0.5 * vpk / max(abs(c), 1e-300)))
    return out


def _judge(m: dict) -> tuple[bool, str]:
    if "viscous_slope" not in m:
        return False, "too little motion to read a map"
    checks = [
        (m["sliding_fraction"] >= 0.4, f"slides only {m['sliding_fraction']:.0%} of the cycle"),
        (m["sign_agreement"] >= 0.95, f"friction follows sgn(v) only {m['sign_agreement']:.0%} of the high-speed branch"),
        (m["coulomb_level"] > 0, "no Coulomb level on the high-speed branch"),
        (m["viscous_slope"] > 0 and m["slope_tstat"] >= 10, "viscous slope not determined"),
        (m["viscous_rise"] >= 0.05, f"viscous rise only {m['viscous_rise']:.1%} of the Coulomb level"),
        (m["curvature"] <= 0.3, f"high-speed branch still curved (slope change {m['curvature']:.0%})"),
        (m["residual"] <= 0.1, f"high-speed branch not a line (residual {m['residual']:.1%})"),
    ]
    fails = [why for ok, why in checks if not ok]
    return (not fails), "; ".join(fails)


def _amplitude_for(v: float, m: dict, M: float, f: float) -> float | None:
    """Amplitude that should give peak speed v: first harmonic of c + s v and M w v."""
    if "viscous_slope" not in m or m["coulomb_level"] <= 0:
        return None
    w = 2 * math.pi * f
    return float(math.hypot(m["coulomb_level"] + max(m["viscous_slope"], 0.0) * v, M * w * v))
