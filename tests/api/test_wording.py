"""POST /analyze tells its refusals and hints in its own query parameters (``api.wording``):
the core's messages are produced here by the core itself, never typed in, so a new hint that
names an option the translation misses fails this test."""
from __future__ import annotations

import re

import numpy as np
import pytest

from api.wording import PARAMETERS, in_api_words, report_in_api_words
from bench.errors import InputError
from bench.readers import parse_columns, read_record


def _refusal(**kw) -> str:
    with pytest.raises(InputError) as e:
        read_record(kw.pop("raw"), name="up.csv", **kw)
    return str(e.value)


def _core_messages() -> list[str]:
    t = np.arange(200) * 1e-3
    two = "t,tau1,tau2,q1,q2\n" + "\n".join(f"{a:.3f},0.1,0.2,{a:.4f},{2 * a:.4f}" for a in t)
    named = "t,a,b\n" + "\n".join(f"{a:.3f},0.1,{a:.4f}" for a in t)
    ns = "t,tau,q\n" + "\n".join(f"{int(a * 1e9)},0.1,{a:.4f}" for a in t)
    out = [_refusal(raw=two.encode()),                              # several joints: choose one
           _refusal(raw=two.encode(), joint="7"),                   # a joint no column names
           _refusal(raw=two.encode(), joint="1", columns="t=t,tau=tau1,q=q1"),
           _refusal(raw=named.encode(), columns="t=t,tau=a"),       # a mapping without q
           _refusal(raw=named.encode(), columns="tau=a,q=b"),       # no time, no rate
           _refusal(raw=ns.encode(), time_unit="s", inertia=1.0)]   # ns read as seconds
    for bad in ("t=t,tau=a,q=b,t=c", "x=t", "t='a"):
        with pytest.raises(InputError) as e:
            parse_columns(bad)
        out.append(str(e.value))
    return out


@pytest.fixture(scope="module")
def messages():
    return _core_messages()


def test_the_core_refusals_name_no_option_the_service_lacks_when_translated(messages, live):
    """Each refusal names a CLI option before and, translated, only ``POST /analyze``'s query
    parameters after: every ``?name=`` is one the served OpenAPI documents for the route."""
    import httpx
    spec = httpx.get(live.url + "/openapi.json", timeout=10).json()
    served = {p["name"] for p in spec["paths"]["/analyze"]["post"]["parameters"]}
    assert all("--" in m for m in messages), messages
    for m in messages:
        said = in_api_words(m)
        left = re.findall(r"--([a-z][a-z-]*)", said)
        assert not [o for o in left if o in PARAMETERS], (m, said)
        named = set(re.findall(r"\?([a-z_]+)=", said))
        if m.startswith("--") and not said.startswith("?"):    # the option as the subject: "columns: ..."
            named.add(said.split(":")[0])
        assert named and named <= served, (said, served)
        assert "\n" not in said


def test_values_and_prose_are_told_apart():
    assert in_api_words("choose one with --joint N, or map its columns with --columns t=NAME,tau=NAME,q=NAME") \
        == "choose one with ?joint=N, or map its columns with ?columns=t=NAME,tau=NAME,q=NAME"
    assert in_api_words("x: --joint elbow: no column names that joint") == "x: ?joint=elbow: no column names that joint"
    assert in_api_words("give --time-unit if it counts another unit") == "give ?time_unit= if it counts another unit"
    assert in_api_words("a 1 ms step: --time-unit ns)") == "a 1 ms step: ?time_unit=ns)"
    assert in_api_words("--columns: unknown role 'x'") == "columns: unknown role 'x'"
    assert in_api_words("(bench analyze --add damping_fade)") == "(POST /analyze?add=damping_fade)"
    assert in_api_words("--add names an effect twice") == "?add= names an effect twice"
    # what the service has no parameter for is left as it is (there is nothing else to say)
    for kept in ("bench simulate --excitation two-tone", "bench analyze --residuals OUT.csv", "a -- b"):
        assert in_api_words(kept) == kept
    doc = {"warnings": ["give --inertia"], "parameters": {"Fc": 1.0}, "n": [1, "--window START:END"]}
    assert report_in_api_words(doc) == {"warnings": ["give ?inertia="], "parameters": {"Fc": 1.0},
                                        "n": [1, "?window=START:END"]}
