"""Schema-driven fuzzing (schemathesis) of the live loopback server: no 5xx, and every answer
conforms to the OpenAPI schema (status codes, content types, bodies).

Bounded and deterministic: a few dozen derandomized examples per operation.  The server
behind it is real (uvicorn, SQLite, keys) but its bench is built so that any run the fuzzer
manages to start fails at once, when it opens its drive: the joint's virtual preset does not
exist.  Nothing is stubbed; the fuzzer's e-stop latches, which it is allowed to do.
"""
from __future__ import annotations

import textwrap

import pytest
import schemathesis
from hypothesis import HealthCheck, given, settings
from schemathesis.config import SchemathesisConfig

from api.app import ServiceConfig, build_service, create_app
from api.server import serve_in_thread

FAIL_FAST_BENCH = textwrap.dedent("""
    name = "fuzz"
    description = "runs fail fast: the joint's virtual preset does not exist"
    [[joints]]
    id = "f1"
    preset = "no-such-preset"
    transport = "simulated"
    inertia = 1.0
    position_limits = [-1.0, 1.0]
    velocity_limit = 1.0
    torque_limit = 1.0
""")


@pytest.fixture(scope="module")
def fuzz_server(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    (d / "fuzz.toml").write_text(FAIL_FAST_BENCH)
    conf = ServiceConfig(bench=str(d / "fuzz.toml"), data_dir=d / "data", transport="simulated", api_key="")
    svc, admin_file = build_service(conf)
    # the fuzz sends thousands of unauthenticated requests on purpose (schemathesis' auth
    # checks expect 401/403 for each); the failed-auth budget has its own test
    # (test_crash_and_limits), and here it would turn the fuzz's later answers into 429s
    from api.limits import AuthFailures
    svc.auth_failures = AuthFailures(burst=10 ** 9)
    with serve_in_thread(create_app(conf, svc)) as url:
        yield url, admin_file.read_text().strip()


@pytest.fixture(scope="module")
def fuzz_schema(fuzz_server):
    url, admin_key = fuzz_server
    # the key goes through the schema's security scheme, so schemathesis knows which requests
    # it meant to send without one (and then expects 401)
    #
    # Every check runs.  One is told a fact the schema cannot state: a schema-valid CSV body
    # can still be no usable record (/analyze), and a schema-valid tracking run can name a
    # joint with no identified model yet (/runs); both answer 422 with the reason, so 422 is
    # an accepted answer to positive data there, and only there.
    accepts_422 = {"positive_data_acceptance": {"expected-statuses": [
        "2xx", "3xx", "401", "403", "404", "409", "422", "429", "5xx"]}}
    config = SchemathesisConfig.from_dict({
        "auth": {"openapi": {"HTTPBearer": {"bearer": admin_key}}},
        "operations": [{"include-path": ["/analyze", "/runs"], "include-method": "POST", "checks": accepts_422}]})
    return schemathesis.openapi.from_url(f"{url}/openapi.json", config=config)


def test_no_server_error_and_schema_conformance(fuzz_schema):
    """Every operation of the live schema, 30 derandomised examples each.  Driven through
    schemathesis' hypothesis strategies directly (its pytest plugin reads pytest internals
    that change between pytest releases)."""
    operations = [result.ok() for result in fuzz_schema.get_all_operations()]
    assert len(operations) >= 15

    for operation in operations:
        @given(case=operation.as_strategy())
        @settings(max_examples=30, derandomize=True, deadline=None, database=None,
                  suppress_health_check=list(HealthCheck))
        def check(case):
            case.call_and_validate(timeout=30)      # every built-in check, none excluded

        check()


def test_fuzzed_runs_ended_cleanly(fuzz_server):
    """Whatever runs the fuzzer started have ended, none by an internal error (a crash)."""
    import time

    import httpx
    url, admin_key = fuzz_server
    with httpx.Client(base_url=url, headers={"Authorization": f"Bearer {admin_key}"}, timeout=10) as c:
        deadline = time.monotonic() + 60
        while True:
            runs = c.get("/runs", params={"limit": 500}).json()["runs"]
            if all(r["state"] not in ("queued", "running") for r in runs) or time.monotonic() > deadline:
                break
            time.sleep(0.2)
    assert all(r["state"] not in ("queued", "running") for r in runs)
    assert not [r for r in runs if "internal error" in (r["error"] or "")]
    print(f"{len(runs)} fuzzed runs: {sorted({(r['procedure'], r['state'], (r['error'] or '')[:60]) for r in runs})}")
