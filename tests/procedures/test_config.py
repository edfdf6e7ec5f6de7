import pytest

from bench.errors import InputError
from procedures.config import declared_inertia, gravity_torque, load_bench


def test_builtin_presets_load():
    micro, macro = load_bench("micro2"), load_bench("macro4")
    assert micro.ids == ["linear", "rotary"] and macro.ids == ["j1", "j2", "j3", "j4"]
    assert {j["transport"] for j in micro.joints} == {"canopen", "serial"}
    assert [j["transport"] for j in macro.joints] == ["canopen", "canopen", "serial", "serial"]
    assert all(j["velocity_limit"] < 0.4 for j in macro.joints)
    j2 = macro.joint("j2")
    assert declared_inertia(j2, {"j2": 0.3}) == pytest.approx(180.0)
    assert gravity_torque(j2, 0.0) == pytest.approx(2400.0)


BAD = [
    ("joints = 3", "no [[joints]]"),
    ("[[joints]]\nid='a'\ntransport='usb'", "transport must be one of"),
    ("[[joints]]\nid='a'\ntransport='simulated'\ninertia=1\nposition_limits=[1,-1]\nvelocity_limit=1\ntorque_limit=1",
     "lo < hi"),
    ("[[joints]]\nid='a'\ntransport='simulated'\ninertia=-2\nposition_limits=[-1,1]\nvelocity_limit=1\ntorque_limit=1",
     "inertia must be positive"),
    ("[[joints]]\nid='a'\ntransport='simulated'\ninertia=1\nposition_limits=[-1,1]\nvelocity_limit=1\ntorque_limit=1\nhold=5",
     "hold position"),
    ("this is = not toml [", "not valid TOML"),
]


@pytest.mark.parametrize("text,message", BAD)
def test_bad_config_one_line(tmp_path, text, message):
    p = tmp_path / "b.toml"
    p.write_text(text)
    with pytest.raises(InputError) as e:
        load_bench(p)
    assert message in str(e.value) and "\n" not in str(e.value)


def test_unknown_bench():
    with pytest.raises(InputError, match="no such bench file"):
        load_bench("nope")
