"""The ``bench`` command line.

    bench simulate   a virtual joint -> record CSV, shaped like users' data if asked
    bench analyze    identify the LuGre model of a record, diagnose what it misses
    bench calibrate  overnight calibration of a bench (procedures)
    bench serve      the REST service (api)

User errors print one line on stderr and exit with status 2.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import List, Optional

import typer
from rich.console import Console
from rich.table import Table

from bench.errors import BenchError

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Identify and compensate LuGre friction in robot joints.")
err = Console(stderr=True)
out = Console()


def fail(message: str) -> None:
    err.print(f"error: {message}", markup=False, highlight=False, soft_wrap=True)
    raise typer.Exit(2)


@app.command()
def simulate(
    joint: str = typer.Option("j1", help="virtual joint preset: linear, rotary, j1..j4"),
    condition: Optional[str] = typer.Option(None, help="a named recording condition, e.g. 'coloured process noise' (see README); the options below override it"),
    excitation: Optional[str] = typer.Option(None, help="sine (the paper's torque sine), two-tone (two torque sines, golden-ratio frequencies), pd (PD tracking; the torque column is the controller's output) or sweep (PD at constant speeds, slowest first: the friction-velocity map experiment)"),
    amplitude: Optional[float] = typer.Option(None, help="torque amplitude [N·m or N] of sine / two-tone (two-tone: the peak of both); preset default if omitted"),
    frequency: Optional[float] = typer.Option(None, help="excitation frequency [Hz] (two-tone: the first tone; pd: the reference's first sine); preset default if omitted"),
    tone2_amplitude: Optional[float] = typer.Option(None, help="two-tone: amplitude of the second tone (with --tone2-frequency; default: 65:35 split of --amplitude)"),
    tone2_frequency: Optional[float] = typer.Option(None, help="two-tone: frequency of the second tone [Hz] (default: golden ratio x --frequency)"),
    reference_amplitude: Optional[float] = typer.Option(None, help="pd: total amplitude of the two reference sines \\[rad or m] (default: from the velocity, travel and torque limits)"),
    bandwidth: Optional[float] = typer.Option(None, help="pd: natural frequency of the PD loop \\[rad/s] (default: 5x the reference, at least 60)"),
    duration: Optional[float] = typer.Option(None, help="record length \\[s] (default 20; a sweep lasts as its speeds need)"),
    speeds: Optional[int] = typer.Option(None, help="sweep: how many constant speeds, 4-40 (default 12)"),
    map_: bool = typer.Option(False, "--map", help="sweep: write the friction-velocity map (a row per constant-speed pass: mean velocity, mean torque) instead of the samples"),
    rate: Optional[float] = typer.Option(None, help="control and sample rate [Hz] (default 1000)"),
    seed: int = typer.Option(0, help="noise seed"),
    process_noise: Optional[float] = typer.Option(None, help="std of a disturbance torque the joint feels and the record does not contain [N·m or N]"),
    process_noise_tau: Optional[float] = typer.Option(None, help="correlation time of the process noise \\[s]: low-pass (AR(1)) noise; with --process-noise-colour pink, the longest"),
    process_noise_colour: Optional[str] = typer.Option(None, help="white, lowpass or pink (1/f); default white, lowpass when --process-noise-tau is given"),
    torque_noise: Optional[float] = typer.Option(None, help="std of the torque (or friction) reading noise: measurement noise only"),
    encoder_resolution: Optional[float] = typer.Option(None, help="position per encoder count"),
    torque_resolution: Optional[float] = typer.Option(None, help="the torque (or friction) reading's step, e.g. a CiA 402 drive's 0x6077 in per-mille of its rated torque"),
    encoder: Optional[str] = typer.Option(None, help="a geared joint's encoder (backlash, joint_flexibility): motor (default) or load; written to the record as 'encoder' (a PD loop closes on the motor's either way)"),
    logger: bool = typer.Option(False, "--logger", help="sample like a PC logger: jittered 1-13 ms steps, dropped samples, occasional stalls"),
    logger_step: Optional[float] = typer.Option(None, help="the logger's mean step \\[s] (default 0.004; steps stay within 1-13 ms)"),
    logger_drop: Optional[float] = typer.Option(None, help="probability that the logger loses a sample (default 0.01)"),
    logger_gaps: Optional[float] = typer.Option(None, help="logger stalls of 30-300 ms per minute (default 2)"),
    logger_start: Optional[float] = typer.Option(None, help="the logger's first timestamp \\[s], e.g. a Unix time (default 0)"),
    output_kind: Optional[str] = typer.Option(None, help="torque (the applied torque) or friction (tau - M q'' from the true states, as torque-sensing arms publish; inertia 0 in the metadata)"),
    velocity_column: bool = typer.Option(False, "--velocity-column", help="also write qd, the joint velocity"),
    torque_offset: Optional[float] = typer.Option(None, help="constant offset left in the recorded torque or friction column (the joint does not feel it)"),
    gravity_left: Optional[str] = typer.Option(None, help="uncompensated gravity left in the recorded column: 'A,B' for A sin q + B cos q, or 'joint' for the preset's own"),
    declared_inertia: Optional[float] = typer.Option(None, help="inertia written to the record (default: the true one)"),
    rest: Optional[float] = typer.Option(None, help="seconds the joint is held still before the motion and after it, inside --duration (a robot holding its pose)"),
    pause: Optional[float] = typer.Option(None, help="seconds the joint is held still in the middle of the motion (between two moves), inside --duration"),
    param: List[str] = typer.Option([], "--param", help="override a friction parameter, e.g. --param Fc=2.0 (also delta)"),
    effect: List[str] = typer.Option([], "--effect", help="inject a hidden effect, e.g. cogging:amplitude=0.4,pitch=0.025"),
    output: Path = typer.Option(..., "--output", "-o", help="CSV file to write"),
):
    """Simulate a virtual joint and write a record CSV: the paper's torque sine by default;
    other excitations, noise models, loggers and outputs shape it like users' data."""
    try:
        from bench.effects.inject import parse_injections
        from bench.validate import finite_arrays, friction_parameter, simulate_settings
        from virtual_drives.conditions import make_record, recording_for
        from virtual_drives.recording import Logger, Recording
        from virtual_drives.presets import preset
        spec = preset(joint)
        if param:
            changes = {}
            for p in param:
                k, _, v = p.partition("=")
                if k not in spec.friction.as_dict(with_delta=True):
                    raise BenchError(f"--param {p!r}: unknown parameter {k!r}; known: Fc, Fs, alpha, sigma0, sigma1, sigma2, delta")
                try:
                    value = float(v)
                except ValueError:
                    raise BenchError(f"--param {p!r}: value must be a number") from None
                changes[k] = friction_parameter(k, value)
            spec = spec.with_(friction=spec.friction.with_(**changes))
        rec = recording_for(spec, condition, seed) if condition else Recording()
        given = {k: v for k, v in dict(
            excitation=excitation, amplitude=amplitude, frequency=frequency, bandwidth=bandwidth, rate=rate,
            process_noise=process_noise, process_noise_tau=process_noise_tau, torque_noise=torque_noise,
            encoder_resolution=encoder_resolution, output=output_kind, torque_offset=torque_offset,
            encoder=encoder, rest=rest, pause=pause, torque_resolution=torque_resolution).items()
            if v is not None}
        rec = rec.with_(**given)
        if speeds is not None:
            rec = rec.with_(speeds=speeds)
        duration = _sweep_length(spec, rec, duration, speeds, map_)
        if process_noise_colour is not None or process_noise_tau is not None:
            colour = process_noise_colour or ("lowpass" if rec.process_noise_tau > 0 else "white")
            rec = rec.with_(process_noise_colour=colour)
        if tone2_amplitude is not None or tone2_frequency is not None:
            if tone2_amplitude is None or tone2_frequency is None:
                raise BenchError("--tone2-amplitude and --tone2-frequency go together")
            rec = rec.with_(tone2=(tone2_amplitude, tone2_frequency))
        if reference_amplitude is not None:
            from virtual_drives.recording import GOLDEN
            f = rec.frequency if rec.frequency is not None else spec.excitation[1]
            rec = rec.with_(reference=((0.625 * reference_amplitude, f), (0.375 * reference_amplitude, GOLDEN * f)))
        if logger or any(x is not None for x in (logger_step, logger_drop, logger_gaps, logger_start)):
            lg = rec.logger or Logger()
            rec = rec.with_(logger=Logger(
                step=lg.step if logger_step is None else logger_step,
                drop=lg.drop if logger_drop is None else logger_drop,
                gaps_per_minute=lg.gaps_per_minute if logger_gaps is None else logger_gaps,
                start=lg.start if logger_start is None else logger_start))
        if velocity_column:
            rec = rec.with_(velocity_column=True)
        if gravity_left is not None:
            rec = rec.with_(gravity_left=_gravity_pair(gravity_left, spec))
        ev, inertia_factor, delta, lag = parse_injections(effect, spec)
        finite_arrays("--effect", values=ev, inertia_factor=inertia_factor, delta=delta, torque_lag=lag)
        # every number checked before anything is allocated (a 1e9 s record, a 1e12 Hz rate);
        # the recording's own settings by Recording.check inside make_record
        simulate_settings(rec.amplitude if rec.amplitude is not None else spec.excitation[0],
                          rec.frequency if rec.frequency is not None else spec.excitation[1],
                          duration, rec.rate, seed, rec.torque_noise, rec.encoder_resolution, declared_inertia)
        record, truth = make_record(spec, rec, seed=seed, duration=duration, effects=effect,
                                    declared_inertia=declared_inertia)
        finite_arrays(f"joint {spec.name}", t=record.t, tau=record.tau, q=record.q, qd=record.qd)
        record.meta["condition"] = condition or "custom"
        if map_:
            from virtual_drives.velocity_sweep import map_points, write_map
            v, F = map_points(record, truth)
            write_map(output, v, F, record)
        else:
            record.to_csv(output)
    except BenchError as e:
        fail(str(e))
    except OSError as e:
        fail(f"cannot write {output}: {e.strerror}")
    lo, hi = spec.position_limits
    q = truth.q
    what = {"sine": "torque sine", "two-tone": "two torque tones", "pd": "PD tracking",
            "sweep": f"velocity sweep at {rec.speeds} speeds"}[rec.excitation]
    if map_:
        out.print(f"wrote {output}: a friction-velocity map of {len(v)} constant-speed passes "
                  f"({min(abs(v)):.4g} to {max(abs(v)):.4g} {spec.position_unit}/s), joint {spec.name}, "
                  f"{what} over {duration:.0f} s")
        return
    out.print(f"wrote {output}: {len(record.t)} samples, joint {spec.name}, {what}, "
              f"{'friction' if rec.output == 'friction' else 'torque'} column, "
              f"q in [{q.min():.4g}, {q.max():.4g}] (workspace [{lo:g}, {hi:g}])")


def _sweep_length(spec, rec, duration, speeds, map_) -> float:
    """A sweep lasts as its speeds need; --speeds and --map belong to it alone."""
    if rec.excitation != "sweep":
        if speeds is not None or map_:
            raise BenchError(f"{'--map' if map_ else '--speeds'} needs --excitation sweep: a map's points are "
                             f"constant-speed passes")
        return 20.0 if duration is None else duration
    if duration is not None:
        raise BenchError("--duration: a sweep lasts as its speeds need; choose how many with --speeds")
    from virtual_drives.velocity_sweep import duration as sweep_duration
    return sweep_duration(spec, rec.speeds, rec.rate)


def _gravity_pair(text: str, spec) -> tuple[float, float]:
    if spec.joint_type != "revolute":
        raise BenchError("--gravity-left applies to revolute joints only")
    if text.strip() == "joint":
        if spec.gravity == (0.0, 0.0):
            raise BenchError(f"--gravity-left joint: joint {spec.name} carries no gravity; give 'A,B'")
        return spec.gravity
    parts = text.split(",")
    try:
        a, b = (float(x) for x in parts)
    except ValueError:
        raise BenchError(f"--gravity-left {text!r}: expected 'A,B' (A sin q + B cos q) or 'joint'") from None
    return a, b


def _inertia_option(text: str | None) -> float | str | None:
    """--inertia: a number >= 0 or 'estimate'."""
    from bench.records import inertia_setting
    try:
        return inertia_setting(text)
    except BenchError as exc:
        raise BenchError(f"--{exc}") from None


@app.command()
def analyze(
    file: Path = typer.Argument(..., help="record: CSV (any delimiter; # metadata lines), Parquet or MATLAB .mat, any of them compressed (gzip, bzip2, xz, zstd) or zipped"),
    columns: Optional[str] = typer.Option(None, help="map the file's columns: t=NAME,tau=NAME,q=NAME[,qd=NAME]; NAME@TIME: a column with a time column of its own"),
    joint: Optional[str] = typer.Option(None, help="a log of several joints: this joint's columns, by its number or name as the column names hold it (q3, position[3], /joint_states/panda_joint4/effort)"),
    inertia: Optional[str] = typer.Option(None, help="M_jj [SI]; overrides the metadata; 0: tau is the friction; estimate: read it off the record"),
    joint_type: Optional[str] = typer.Option(None, help="revolute or prismatic (overrides the metadata)"),
    time_unit: Optional[str] = typer.Option(None, help="s, ms, us or ns (numeric time; default s), or K*UNIT (25*ns: 40 MHz ticks)"),
    sample_rate: Optional[float] = typer.Option(None, help="the rows' rate [Hz], for a file without a time column (a scope's export; or a '# sample_rate: HZ' line)"),
    window: Optional[str] = typer.Option(None, help="START:END seconds from the first sample: the part of a long log to analyse"),
    position_unit: Optional[str] = typer.Option(None, help="rad, deg, rev (revolute); m, mm, um (prismatic); or K*UNIT (counts: 0.00153398*rad)"),
    torque_unit: Optional[str] = typer.Option(None, help="N*m, mN*m, kN*m, N*mm (revolute); N, mN, kN (prismatic); or K*UNIT (amperes: 0.12*N*m)"),
    torque_hold: Optional[str] = typer.Option(None, help="zoh (commands held), sample (sampled) or auto"),
    encoder: Optional[str] = typer.Option(None, help="a geared joint's encoder: motor (default) or load (overrides the metadata; a Parquet or .mat log has no '#' line to say it)"),
    json_out: Optional[Path] = typer.Option(None, "--json", help="write the JSON report here"),
    residuals: Optional[Path] = typer.Option(None, help="write t, measured, baseline, final, held_out at the file's own timestamps (CSV)"),
    plots: Optional[Path] = typer.Option(None, help="directory for PNG plots"),
    report: Optional[Path] = typer.Option(None, help="write an HTML report (with plots) here"),
    add: Optional[str] = typer.Option(None, help="refit with these effects, comma-separated"),
    no_diagnosis: bool = typer.Option(False, "--no-diagnosis", help="identify only"),
    cutoff: Optional[float] = typer.Option(None, help="low-pass cutoff [Hz] (default: automatic)"),
):
    """Identify the LuGre model of a record and diagnose what it misses."""
    from bench.analysis import analyze_record
    from bench.readers import read_record
    try:
        inertia = _inertia_option(inertia)
        rec = read_record(file, columns=columns, joint_type=joint_type, position_unit=position_unit,
                          torque_unit=torque_unit, inertia=inertia, torque_hold=torque_hold,
                          time_unit=time_unit, window=window, sample_rate=sample_rate, joint=joint,
                          encoder=encoder)
        effects = [e.strip() for e in add.split(",") if e.strip()] if add is not None else None
        result = analyze_record(rec, inertia=inertia, add=effects, diagnose_effects=not no_diagnosis,
                                cutoff=cutoff, name=str(file))
        if plots is not None or report is not None:
            result.write_plots(plots or (report.parent / (report.stem + "_plots")))
        if report is not None:
            result.write_html(report)
        doc = result.report()
        if json_out is not None:
            json_out.write_text(json.dumps(doc, indent=2))
        if residuals is not None:
            result.write_residuals(residuals)
    except BenchError as e:
        fail(str(e))
    except OSError as e:
        fail(f"{e.filename or file}: {e.strerror}")
    _print_report(doc)


def _print_report(doc: dict) -> None:
    if doc.get("record") == "friction_map":     # bench.friction_map
        out.print(f"read as a friction-velocity map: {doc['input']['points']} points at steady speeds "
                  f"(no time, no position)", markup=False, highlight=False)
    t = Table(title="Identified LuGre model", show_lines=False)
    for col in ("parameter", "value", "std. error", "identifiable"):
        t.add_column(col)
    for k, v in doc["parameters"].items():
        se = doc["uncertainty"].get(k)
        t.add_row(k, f"{v:.6g}", "-" if se is None else f"{se:.3g}",
                  "yes" if doc["identifiable"].get(k) else "NO")
    out.print(t)
    fit = doc["fit"]
    out.print(f"fit: rms error {fit['rms_error']:.4g}, NRMSE {fit['nrmse']:.4f} "
              f"({fit.get('fit_percent', 0):.1f} % fit)")
    if "baseline" in doc:
        out.print(f"held-out rms error: baseline {doc['baseline']['rms_error']:.4g}"
                  + (f" -> final {doc['final']['rms_error']:.4g} with {', '.join(doc['final']['effects']) or 'no effects'}"
                     if doc.get("final") else ""))
    for d in doc.get("diagnosis", []):
        mark = "*" if d["significant"] else " "
        out.print(f" {mark} {d['effect']:<28} {d['rms_before']:.4g} -> {d['rms_after']:.4g}  {d['evidence']}",
                  markup=False, highlight=False)
    left = doc.get("unexplained")
    if left and left["structured"]:
        out.print(f"still unexplained: {left['evidence']}", markup=False, highlight=False)
    for w in doc.get("warnings", []):
        out.print(f"warning: {w}", markup=False, highlight=False)


def _register_plugins() -> None:
    """Sub-commands that live with their layer (procedures, api)."""
    for mod in ("procedures.cli", "api.cli"):
        try:
            module = __import__(mod, fromlist=["register"])
        except ModuleNotFoundError as e:
            if e.name == mod:  # that layer is not installed; anything else is a real bug
                continue
            raise
        module.register(app)


_register_plugins()


def run(argv: list[str] | None = None) -> int:
    """The CLI on ``argv`` (default: the process's); returns the exit status.  Usage errors
    (unknown option, a value that is not a number, a missing argument) are one line, status
    2, like every other user error (click would print a framed usage box)."""
    try:       # typer >= 0.26 carries its own copy of click
        from typer._click import exceptions as cx
    except ImportError:
        from click import exceptions as cx
    try:
        rv = app(args=argv, prog_name="bench", standalone_mode=False)
    except cx.NoArgsIsHelpError as e:
        err.print(e.ctx.get_help() if e.ctx is not None else str(e), markup=False, highlight=False)
        return 2
    except cx.UsageError as e:
        where = f"{e.ctx.command_path}: " if e.ctx is not None and e.ctx.command_path else ""
        err.print(f"error: {where}{' '.join(e.format_message().split())}", markup=False, highlight=False,
                  soft_wrap=True)
        return 2
    except (typer.Exit, getattr(cx, "Exit", typer.Exit)) as e:   # typer >= 0.26: its own Exit
        return e.exit_code
    except (typer.Abort, getattr(cx, "Abort", typer.Abort)):
        err.print("aborted", markup=False, highlight=False)
        return 130
    except BenchError as e:  # a plugin command that let one through
        err.print(f"error: {' '.join(str(e).split())}", markup=False, highlight=False, soft_wrap=True)
        return 2
    return rv if isinstance(rv, int) else 0


def main() -> None:
    sys.exit(run())


if __name__ == "__main__":
    main()
