"""``bench serve`` (the REST service) and ``bench api-key`` (create a key offline).

``register(app)`` adds both to the ``bench`` Typer app.  Bad input prints one line on
stderr and exits 2.
"""
from __future__ import annotations

from pathlib import Path

import typer

from bench.errors import BenchError


def _fail(message: str) -> None:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(2)


def register(app: typer.Typer) -> None:
    @app.command("serve")
    def serve_cmd(
        bench: str = typer.Option("macro4", "--bench", help="built-in bench (micro2, macro4) or a TOML file"),
        host: str = typer.Option("127.0.0.1", "--host", help="address to bind (loopback by default)"),
        port: int = typer.Option(8000, "--port", help="TCP port"),
        data: Path = typer.Option(Path("bench-data"), "--data", help="directory of the run store and API keys"),
        transport: str = typer.Option("virtual", "--transport",
                                      help="virtual (emulated CANopen/serial drives), simulated (in-process plugs) "
                                           "or hardware (the drives the bench file names)"),
        log_level: str = typer.Option("info", "--log-level", help="uvicorn log level"),
        pin_cpus: bool = typer.Option(True, "--pin-cpus/--no-pin-cpus",
                                      help="server on the last CPU, run control processes on the others"),
        rt_priority: int = typer.Option(0, "--rt-priority",
                                        help="SCHED_FIFO priority of real-time benches' run control processes, "
                                             "1-98 (needs root, CAP_SYS_NICE or an rtprio limit); 0: normal"),
    ) -> None:
        """The REST service: runs, live events, compensation, e-stop (FastAPI on uvicorn)."""
        from api.app import ServiceConfig, build_service, create_app
        from api.auth import ENV_KEY
        from api.server import serve_forever
        from api.server import listen
        if not 0 < port < 65536:
            _fail(f"--port must be in 1..65535, got {port}")
        try:      # first: a busy port is one line, before the store and keys are touched
            sock = listen(host, port)
        except OSError as e:
            _fail(f"cannot listen on {host}:{port}: {e.strerror or e}")
        try:
            conf = ServiceConfig(bench=bench, data_dir=data, transport=transport, pin_cpus=pin_cpus,
                                 rt_priority=rt_priority)
            svc, admin_file = build_service(conf)
        except BenchError as e:
            _fail(str(e))
        if host not in ("127.0.0.1", "localhost", "::1"):
            typer.echo(f"warning: binding {host}: the bench is reachable from the network; keys are sent in clear "
                       f"over plain HTTP", err=True)
        shown = f"[{host}]" if ":" in host else host
        typer.echo(f"friction-bench API on http://{shown}:{port}  (bench {svc.cfg.name}, {transport} drives, "
                   f"data {data})")
        typer.echo(f"  OpenAPI docs: http://{shown}:{port}/docs")
        if svc.runs.control_cpus:
            typer.echo(f"  CPUs: run control processes on {sorted(svc.runs.control_cpus)}, the server on the rest")
        if rt_priority:
            note = "" if svc.cfg.clock == "realtime" else f" (not this {svc.cfg.clock} bench: it never waits for a clock)"
            typer.echo(f"  real-time runs' control processes at SCHED_FIFO priority {rt_priority}{note}; "
                       f"where not permitted a run logs why and runs at normal priority")
        if admin_file is not None:
            typer.echo(f"  admin key: in {admin_file.resolve()} (mode 0600)")
        else:
            typer.echo(f"  admin key: an admin key exists in {svc.keys.path.resolve()} (hashed); "
                       f"its file was removed — use ${ENV_KEY} or create keys with 'bench api-key'")
        typer.echo(f"  ${ENV_KEY} is {'set: accepted as an admin key' if svc.keys._env_digest else 'not set'}")
        serve_forever(create_app(conf, svc), host, port, log_level, sock=sock)

    @app.command("api-key")
    def api_key_cmd(
        role: str = typer.Argument(..., help="observer, operator or admin"),
        name: str = typer.Option("", "--name", help="who or what the key is for"),
        data: Path = typer.Option(Path("bench-data"), "--data", help="the service's data directory"),
    ) -> None:
        """Create an API key in the data directory (prints the key once; only its hash is kept).
        A running server picks it up at the next request."""
        from api.auth import KeyStore
        try:
            key, info = KeyStore(data).create(role, name)
        except BenchError as e:
            _fail(str(e))
        except OSError as e:
            _fail(f"{data}: {e.strerror or e}")
        typer.echo(key)
        typer.echo(f"{info['role']} key {info['id']} ({info['name']}) stored hashed in {Path(data) / 'api_keys.json'}",
                   err=True)
