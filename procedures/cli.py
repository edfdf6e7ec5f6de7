"""``bench calibrate``: the overnight calibration from the command line.

``register(app)`` adds the command to a Typer app (the lead wires it into ``bench``).
Bad input prints one line on stderr and exits 2, without a traceback.  Exit 0 when every
joint calibrated, 1 when the run ended but some joint failed (the report says why), 130 when
Ctrl-C cancelled it: the first Ctrl-C is a cancel (the joints brake under control, a fit stops
at its next evaluation, the run ends ``cancelled`` and ``--resume`` goes on from there); a
second one stops at once (the rig's close quick-stops the drives).
"""
from __future__ import annotations

import json
import signal
import sys
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import Optional

import typer

from bench.errors import BenchError


def register(app: typer.Typer) -> None:
    @app.command("calibrate")
    def calibrate_cmd(
        bench: str = typer.Option(..., "--bench", help="built-in bench (micro2, macro4) or a TOML file"),
        joints: Optional[str] = typer.Option(None, "--joints", help="comma-separated joint ids (default: all)"),
        json_out: Optional[Path] = typer.Option(None, "--json", help="also write the JSON report here"),
        resume: bool = typer.Option(False, "--resume", help="continue the last interrupted calibration"),
        data: Path = typer.Option(Path("bench-data"), "--data", help="directory of the run store"),
        seed: int = typer.Option(0, "--seed", help="seed of the virtual drives"),
        plots: bool = typer.Option(True, "--plots/--no-plots", help="write PNG plots"),
        transport: str = typer.Option("virtual", "--transport",
                                      help="virtual (emulated CANopen/serial drives reached through the real "
                                           "protocol stacks; default), simulated (in-process plugs, fast) or "
                                           "hardware (the drives the bench file names: CAN adapter, serial port)"),
        excitation: Optional[str] = typer.Option(None, "--excitation",
                                                 help="search waveform: sine, or two_level (alternate cycles at "
                                                      "1 and 0.6 of the amplitude: breaks the cycle lock); "
                                                      "default: SearchSettings.waveform"),
        rt_priority: int = typer.Option(0, "--rt-priority",
                                        help="SCHED_FIFO priority of this process, 1-98, for real-time benches "
                                             "(needs root, CAP_SYS_NICE or an rtprio limit); 0: normal"),
    ) -> None:
        """Search excitation, identify and validate by tracking, joint after joint."""
        try:
            if transport not in ("simulated", "virtual", "hardware"):
                raise BenchError(f"--transport must be virtual, simulated or hardware, got {transport!r}")
            from drivers.realtime import check_priority
            check_priority(rt_priority, "--rt-priority")
            if excitation is not None:
                from procedures.waveforms import check
                check(excitation, 0.6, "--excitation")
            code = _calibrate(bench, joints, json_out, resume, data, seed, plots, transport, rt_priority,
                              excitation)
        except BenchError as e:
            typer.echo(f"error: {e}", err=True)
            raise typer.Exit(2)
        raise typer.Exit(code)


def _calibrate(bench, joints, json_out, resume, data, seed, plots, transport="virtual", rt_priority=0,
               excitation=None) -> int:
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from bench.errors import InputError
    from bench.store import Store
    from procedures.calibration import (STAGES, CalibrationSettings, calibrate, latest_resumable,
                                        start_calibration)
    from procedures.config import load_bench
    from procedures.excitation import SearchSettings

    ids = [j.strip() for j in joints.split(",") if j.strip()] if joints else None
    if joints is not None and not ids:
        raise InputError("--joints is empty")
    cfg = load_bench(bench)          # validate before touching the store
    for w in cfg.warnings:
        typer.echo(f"warning: {w}", err=True)
    chosen = cfg.select(ids)
    if transport == "virtual":
        from procedures.calibration import check_virtual
        check_virtual(cfg)
    if rt_priority and cfg.clock == "realtime":   # before the drives' threads: they inherit it
        from drivers.realtime import set_priority
        why_not = set_priority(rt_priority)
        if why_not:
            typer.echo(f"warning: {why_not}", err=True)
    try:
        store = Store(data)
    except (OSError, Exception) as e:
        if isinstance(e, BenchError):
            raise
        raise InputError(f"{data}: cannot open the run store ({e.__class__.__name__}: {e})") from None
    store.recover()
    run_id = latest_resumable(store, bench) if resume else start_calibration(
        store, bench, chosen, seed, options={"plots": plots, "rt_priority": rt_priority, "excitation": excitation},
        transport=transport)
    planned = store.get_run(run_id)["config"]["joints"]
    console = Console(stderr=True)
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.fields[status]}"),
                  TimeElapsedColumn(), console=console, transient=False) as progress:
        tasks = {j: progress.add_task(j, total=len(STAGES), status="") for j in planned}

        def on_event(doc: dict) -> None:
            d = doc["data"]
            if doc["name"] == "stage" and d.get("joint") in tasks:
                done = d["status"] in ("done", "failed", "skipped")
                progress.update(tasks[d["joint"]], advance=1 if done else 0,
                                status=f"{d['stage']}: {d['status']}")
            elif doc["name"] == "trial" and d.get("joint") in tasks:
                progress.update(tasks[d["joint"]], status=f"search: trial {d['index']} {d['outcome']}")

        search = SearchSettings() if excitation is None else SearchSettings(waveform=excitation)
        with _ctrl_c_cancels() as cancel:
            report = calibrate(store, run_id, on_event=on_event, cancel=cancel, settings=CalibrationSettings(
                search=search, plots=plots, force_simulated=transport == "simulated", hardware=transport == "hardware"))
    text = json.dumps(report, indent=2, default=str)
    if json_out is not None:
        try:
            Path(json_out).write_text(text)
        except OSError as e:
            raise InputError(f"{json_out}: cannot write the report ({e.__class__.__name__})") from None
    for jid, j in report["joints"].items():
        console.print(f"{jid}: {j['status']}" + (f" — {j['reason']}" if j["reason"] else ""))
    console.print(f"report: {report['files']['html']}")
    if cancel.is_set():
        console.print(f"cancelled ({cancel.reason}); go on with: bench calibrate --bench {bench} "
                      f"--data {data} --resume", soft_wrap=True)
        return 130
    return 0 if all(j["status"] == "succeeded" for j in report["joints"].values()) else 1


@contextmanager
def _ctrl_c_cancels():
    """The first Ctrl-C cancels the calibration (``Cancel``); a second raises
    KeyboardInterrupt as usual.  Only the main thread can own a signal handler, and a SIGINT
    ignored (a shell's background job) stays ignored."""
    from procedures.events import Cancel
    cancel = Cancel()
    if threading.current_thread() is not threading.main_thread() \
            or signal.getsignal(signal.SIGINT) is signal.SIG_IGN:     # a background job's: left so
        yield cancel
        return

    def on_sigint(signum, frame):
        if cancel.is_set():
            raise KeyboardInterrupt
        cancel.set("Ctrl-C")

    previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        yield cancel
    finally:
        signal.signal(signal.SIGINT, previous)


def main() -> None:  # a stand-alone entry point until bench/cli.py wires register()
    app = typer.Typer(add_completion=False)
    register(app)

    @app.command("version")
    def _version():
        import bench
        typer.echo(bench.__version__)
    app(prog_name="bench")


if __name__ == "__main__":
    main()
    sys.exit(0)
