"""Records shaped like users' data (virtual_drives.recording, .conditions): each property of
the generator checked on its own, not through the analysis.  Seeds 5000+ (tests only)."""
import io
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from bench import terms
from bench.cli import app
from bench.errors import InputError
from bench.records import read_csv
from virtual_drives.conditions import CONDITIONS, EXTRA_CONDITIONS, make_record, recording_for
from virtual_drives.joint import quantise
from virtual_drives.presets import PRESETS
from virtual_drives.scenarios import travel_of
from virtual_drives.recording import GOLDEN, Logger, Recording, _hermite, make, process_noise


def autocorr(x, lag):
    x = x - x.mean()
    return float(np.dot(x[:-lag], x[lag:]) / np.dot(x, x))


def test_process_noise_statistics():
    rng = np.random.default_rng(5301)
    dt, n = 1e-3, 200_000
    white = process_noise(n, dt, 2.0, 0.0, "white", rng)
    assert abs(white.std() / 2.0 - 1) < 0.01 and abs(autocorr(white, 1)) < 0.01
    low = process_noise(n, dt, 2.0, 0.02, "lowpass", rng)
    assert abs(low.std() / 2.0 - 1) < 0.1       # 200 s / 20 ms: ~1e4 independent stretches
    for lag in (5, 20, 40):                       # AR(1): r(k) = exp(-k dt / tau)
        assert abs(autocorr(low, lag) - math.exp(-lag * dt / 0.02)) < 0.03
    pink = process_noise(n, dt, 2.0, 2.0, "pink", rng)
    f = np.fft.rfftfreq(n, dt)
    psd = np.abs(np.fft.rfft(pink)) ** 2
    band = lambda lo, hi: psd[(f >= lo) & (f < hi)].mean()
    # 1/f: each decade carries ~10x the power density of the next (white would be 1x)
    for lo in (0.5, 5.0, 50.0):
        assert 4 < band(lo, 2 * lo) / band(10 * lo, 20 * lo) < 25


def test_process_noise_is_felt_not_recorded_and_reading_noise_the_reverse():
    spec = PRESETS["j3"]
    base = Recording(torque_noise=0.0)
    clean, t0 = make(spec, base, 6.0, seed=5302)
    felt, t1 = make(spec, base.with_(process_noise=0.05 * spec.friction.Fc), 6.0, seed=5302)
    read, t2 = make(spec, base.with_(torque_noise=0.02 * spec.friction.Fc), 6.0, seed=5302)
    # process noise: the torque column is the command, the joint moved differently
    assert np.array_equal(felt.tau, clean.tau)
    assert np.allclose(t1.felt - t1.command, t1.disturbance)
    assert np.max(np.abs(t1.q - t0.q)) > 50 * spec.encoder_resolution
    # reading noise: the joint moved exactly as without it, the column carries the noise
    assert np.array_equal(t2.q, t0.q) and np.array_equal(read.q, clean.q)
    assert abs(np.std(read.tau - clean.tau) / (0.02 * spec.friction.Fc) - 1) < 0.05


def test_logger_timestamps_jitter_drops_and_gaps():
    lg = Logger(step=0.004, drop=0.02, gaps_per_minute=6.0)
    t = lg.times(120.0, np.random.default_rng(5303))
    d = np.diff(t)
    assert t[0] == 0 and np.all(d >= lg.min_step - 1e-12)
    assert 0.003 < np.median(d) < 0.004          # gamma(2) steps: median below the mean
    single = d[d <= lg.max_step + 1e-12]
    # 1-13 ms; gamma(2, 1.5 ms) + 1 ms puts 5 % of the steps beyond 8 ms (merged drops add ~1 %)
    assert single.max() > 0.012 and 0.03 < np.mean(single > 0.008) < 0.09
    assert 0.0038 < single.mean() < 0.0045
    n_gaps = np.sum(d > 0.03)                     # stalls of 30-300 ms (a few drops merge too)
    assert 4 <= n_gaps <= 25                      # 12 expected
    kept = len(t) / (120.0 / np.mean(single))     # ~2 % dropped, ~1.5 % of the time in stalls
    assert 0.92 < kept < 0.99


def test_jittered_record_samples_the_truth_at_the_logger_times():
    spec = PRESETS["j1"]
    rec, tr = make(spec, Recording(torque_noise=0.0, logger=Logger(start=1.7e9)), 8.0, seed=5304)
    dt = tr.t[1] - tr.t[0]
    assert rec.t[0] == 1.7e9
    i = ((rec.t - 1.7e9) / dt).astype(int)
    assert np.array_equal(rec.tau, tr.command[i])   # the torque as held at that moment
    assert rec.meta["torque_hold"] == "sample"
    q_lin = tr.at_record(tr.q, rec)
    assert np.max(np.abs(rec.q - q_lin)) < np.max(np.abs(tr.v)) * dt + spec.encoder_resolution
    assert np.all(np.abs(rec.q - quantise(rec.q, spec.encoder_resolution)) < 1e-15 + 1e-9 * np.abs(rec.q))
    # the interpolation itself: Hermite on q and v is 4th-order accurate
    g = np.arange(0, 3, 0.01)
    x = np.random.default_rng(5305).uniform(0, 2.99, 500)
    assert np.max(np.abs(_hermite(x, 0.01, np.sin(g), np.cos(g)) - np.sin(x))) < 1e-9
    text = rec.to_csv()                           # written as logged: uneven t survives
    back = np.loadtxt(text.splitlines(), delimiter=",", comments="#", skiprows=sum(
        line.startswith("#") for line in text.splitlines()) + 1)
    assert np.allclose(back[:, 0], rec.t, rtol=0, atol=1e-6) and len(back) == len(rec.t)


@pytest.mark.parametrize("joint,excitation", [("j1", "sine"), ("j3", "pd")])
def test_friction_output_is_tau_minus_M_qdd_of_the_truth(joint, excitation):
    spec = PRESETS[joint]
    f = spec.friction
    rec, tr = make(spec, Recording(excitation=excitation, output="friction", torque_noise=0.0), 10.0, seed=5306)
    assert rec.meta["inertia"] == 0.0 and "friction" in rec.meta["torque_column"]
    # the continuous LuGre friction at the true states (an independent formula)
    s = f.stribeck(tr.v)
    F = f.sigma0 * tr.z + f.sigma1 * (tr.v - f.sigma0 * np.abs(tr.v) * tr.z / s) + f.sigma2 * tr.v
    err = (rec.tau - F)[1:]
    assert np.sqrt(np.mean(err ** 2)) < 2e-3 * f.Fc and np.percentile(np.abs(err), 99) < 5e-3 * f.Fc
    # offsets, gravity and process noise enter the column; the offset is not felt
    d = 0.03 * f.Fc
    rec2, tr2 = make(spec, Recording(excitation=excitation, output="friction", torque_noise=0.0,
                                     torque_offset=0.25 * f.Fc, gravity_left=(0.0, 0.1 * f.Fc),
                                     process_noise=d), 10.0, seed=5306)
    noise_free, tr3 = make(spec, Recording(excitation=excitation, output="friction", torque_noise=0.0,
                                           torque_offset=0.25 * f.Fc), 10.0, seed=5307)
    assert np.array_equal(tr3.q, tr.q) and np.allclose(noise_free.tau - rec.tau, 0.25 * f.Fc)
    left = rec2.tau - 0.25 * f.Fc - 0.1 * f.Fc * np.cos(rec2.q)
    s2 = f.stribeck(tr2.v)
    F2 = f.sigma0 * tr2.z + f.sigma1 * (tr2.v - f.sigma0 * np.abs(tr2.v) * tr2.z / s2) + f.sigma2 * tr2.v
    # the disturbance is averaged over the two periods around each sample, like the friction
    dbar = np.r_[tr2.disturbance[0], 0.5 * (tr2.disturbance[1:] + tr2.disturbance[:-1])]
    err2 = (left - (F2 - dbar))[1:]
    assert np.sqrt(np.mean(err2 ** 2)) < 2e-3 * f.Fc


@pytest.mark.parametrize("joint,resolution", [("j1", 2e-5), ("rotary", None), ("linear", None)])
def test_pd_tracking_follows_a_smooth_reference_inside_the_workspace(joint, resolution):
    spec = PRESETS[joint]
    if resolution is not None:                             # coarse: the quantisation shows
        spec = spec.with_(encoder_resolution=resolution)
    rec, tr = make(spec, Recording(excitation="pd", torque_noise=0.0), 30.0, seed=5308)
    lo, hi = spec.position_limits
    e = tr.q_ref - tr.q
    assert np.sqrt(np.mean(e ** 2)) < 0.05 * np.std(tr.q_ref)
    assert lo < tr.q.min() and tr.q.max() < hi and np.abs(rec.tau).max() <= spec.torque_limit
    v = tr.v
    assert v.max() > 2 / spec.friction.alpha and v.min() < -2 / spec.friction.alpha  # slides both ways
    # the recorded torque is the PD law on the quantised encoder (velocity by backward difference)
    qm = quantise(tr.q, spec.encoder_resolution)
    vm = np.r_[0.0, np.diff(qm) / 1e-3]
    v_ref = np.gradient(tr.q_ref, tr.t)
    X = np.column_stack([tr.q_ref - qm, v_ref - vm])
    gains, *_ = np.linalg.lstsq(X, rec.tau, rcond=None)
    assert np.max(np.abs(X @ gains - rec.tau)) < 1e-6 * np.abs(rec.tau).max()
    assert gains[0] > 0 and gains[1] > 0


def test_two_tone_spectrum_has_the_two_tones_only():
    spec = PRESETS["linear"]
    a, f = spec.excitation
    rec, _ = make(spec, Recording(excitation="two-tone", torque_noise=0.0), 60.0, seed=5309)
    n = len(rec.tau)
    amp = 2 * np.abs(np.fft.rfft(rec.tau * np.hanning(n))) / np.hanning(n).sum()
    freq = np.fft.rfftfreq(n, 1e-3)
    peak = lambda f0: amp[np.abs(freq - f0) < 0.05].max()
    assert abs(peak(f) / (0.65 * a) - 1) < 0.05 and abs(peak(GOLDEN * f) / (0.35 * a) - 1) < 0.05
    away = (np.abs(freq - f) > 0.2) & (np.abs(freq - GOLDEN * f) > 0.2)
    assert amp[away].max() < 0.01 * a


def test_every_condition_takes_effects_and_is_deterministic():
    spec = PRESETS["j3"]
    fc = spec.friction.Fc
    for name in [*CONDITIONS, *EXTRA_CONDITIONS]:
        plain, t0 = make_record(spec, name, seed=5310, duration=3.0)
        again, _ = make_record(spec, name, seed=5310, duration=3.0)
        assert np.array_equal(plain.tau, again.tau) and np.array_equal(plain.t, again.t), name
        rec, tr = make_record(spec, name, seed=5310, duration=3.0,
                              effects=[f"torque_offset:value={0.3 * fc}", "torque_lag:delay=0.004"])
        assert tr.ev[terms.OFFSET] == pytest.approx(0.3 * fc) and tr.torque_lag == 0.004, name
        assert rec.meta["injected"].startswith("torque_offset") and rec.meta["condition"] == name
        if rec.meta["inertia"] > 0 and tr.recording.logger is None:   # today's reader takes these
            back = read_csv(io.StringIO(plain.to_csv()))
            assert np.allclose(back.tau, plain.tau, rtol=1e-8) and np.allclose(back.t, plain.t, atol=1e-6)
        # the joint felt them: the lagged command, and a motion unlike the plain record's
        i = np.arange(10, len(tr.t))
        lagged = tr.command[i - 4]                    # 4 ms at 1 kHz
        if round(1 / (tr.t[1] - tr.t[0])) == 1000:
            assert np.allclose(tr.felt[i] - tr.disturbance[i], lagged), name
        if tr.recording.excitation == "pd":      # the loop pushes back against the offset
            half = len(tr.t) // 2
            assert np.mean((tr.command - t0.command)[half:]) == pytest.approx(0.3 * fc, rel=0.1), name
        else:
            assert np.max(np.abs(tr.q - t0.q)) > 0.01 * np.ptp(t0.q), name


def test_condition_magnitudes_scale_with_the_joint():
    for joint in ("rotary", "j1"):
        spec = PRESETS[joint]
        fc = spec.friction.Fc
        w = recording_for(spec, "white process noise", 5311)
        c = recording_for(spec, "coloured process noise", 5311)
        r = recording_for(spec, "torque-reading noise only", 5311)
        assert 0.02 * fc <= w.process_noise <= 0.08 * fc and w.process_noise_colour == "white"
        assert 0.01 * fc <= c.process_noise <= 0.04 * fc and 0.005 <= c.process_noise_tau <= 0.05
        assert 0.005 * fc <= r.torque_noise <= 0.03 * fc and r.process_noise == 0
        res = recording_for(spec, "coarse encoder", 5311).encoder_resolution
        assert 12 <= math.log2(travel_of(spec) / res) <= 14 and res > 4 * spec.encoder_resolution
    with pytest.raises(InputError, match="unknown condition"):
        make_record(PRESETS["j1"], "wet floor")


def test_cli_writes_shaped_records_and_refuses_bad_numbers(tmp_path):
    runner = CliRunner()
    out = tmp_path / "log.csv"
    r = runner.invoke(app, ["simulate", "--joint", "j3", "--duration", "4", "--seed", "5312",
                            "--excitation", "pd", "--output-kind", "friction", "--logger",
                            "--velocity-column", "--process-noise", "2", "--process-noise-tau", "0.02",
                            "--torque-offset", "25", "-o", str(out)])
    assert r.exit_code == 0, r.output
    text = out.read_text()
    assert "# inertia: 0.0" in text and "t,tau,q,qd" in text
    t = np.loadtxt([ln for ln in text.splitlines() if ln[0].isdigit()], delimiter=",")[:, 0]
    assert np.ptp(np.diff(t)) > 0.005                 # uneven
    for args, words in ((["--process-noise", "-1"], "--process-noise must be"),
                        (["--process-noise-tau", "nan"], "--process-noise-tau must be"),
                        (["--logger-drop", "2"], "--logger-drop must be"),
                        (["--rate", "inf"], "--rate must be"),
                        (["--excitation", "chirp"], "--excitation must be one of"),
                        (["--gravity-left", "1,x"], "--gravity-left"),
                        (["--condition", "nope"], "unknown condition"),
                        (["--torque-resolution", "-0.5"], "--torque-resolution must be")):
        r = runner.invoke(app, ["simulate", *args, "-o", str(tmp_path / "x.csv")])
        assert r.exit_code == 2 and words in r.output and "Traceback" not in r.output, (args, r.output)


def test_a_torque_read_in_steps_is_written_found_and_reported(tmp_path):
    """``--torque-resolution``: the column holds whole steps (a drive's per-mille counts; 8 N·m is 7.6 % of j3's Fc), the
    reader finds the step (``resampling.torque_resolution``), and a record read exactly has 0."""
    from bench.resample import reading_resolution
    runner = CliRunner()
    out = tmp_path / "pm.csv"
    r = runner.invoke(app, ["simulate", "--joint", "j3", "--duration", "12", "--seed", "5501",
                            "--torque-resolution", "8", "-o", str(out)])
    assert r.exit_code == 0, r.output
    rec = read_csv(out)
    counts = rec.tau / 8
    assert np.allclose(counts, np.round(counts), atol=1e-6) and len(np.unique(counts)) > 20
    assert "-0," not in out.read_text()                    # no negative zeros in the file
    assert reading_resolution(rec.tau) == pytest.approx(8)
    assert reading_resolution(rec.tau + 0.7) == pytest.approx(8)     # a grid off zero
    assert reading_resolution(rec.tau + np.random.default_rng(5502).normal(0, 0.01, len(rec.tau))) == 0.0
    js = tmp_path / "pm.json"
    r = runner.invoke(app, ["analyze", str(out), "--no-diagnosis", "--json", str(js)])
    assert r.exit_code == 0, r.output
    import json
    doc = json.loads(js.read_text())
    assert doc["resampling"]["torque_resolution"] == pytest.approx(8)
    assert any(w.startswith("the torque column sits on steps of 8 N·m") for w in doc["warnings"])
