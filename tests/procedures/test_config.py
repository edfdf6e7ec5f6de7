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


# --- joints described by their own physics ([joints.physics] instead of a preset) ----------
JOINT = ("[[joints]]\nid='w'\ntransport='canopen'\ninertia=0.003\nposition_limits=[-2,2]\n"
         "velocity_limit=10\ntorque_limit=0.5\n[joints.physics]\n")
FRICTION = "friction = { Fc = 0.05, Fs = 0.065, alpha = 2.0, sigma0 = 200.0, sigma1 = 0.05, sigma2 = 0.02 }\n"
GOOD = "inertia = 0.003\n" + FRICTION + "encoder_resolution = 4.8e-5\n"

BAD_PHYSICS = [
    (GOOD + "mass = 3\n", "unknown key physics.mass"),
    ("inertia = -0.003\n" + FRICTION + "encoder_resolution = 4.8e-5\n", "physics.inertia must be positive"),
    ("inertia = nan\n" + FRICTION + "encoder_resolution = 4.8e-5\n", "physics.inertia must be a number"),
    (GOOD.replace("Fc = 0.05", "Fc = inf"), "physics.friction.Fc must be a number"),
    (GOOD.replace("sigma2 = 0.02", "sigma2 = -0.02"), "physics.friction.sigma2 must not be negative"),
    (GOOD.replace(", sigma1 = 0.05", ""), "missing physics.friction.sigma1"),
    (GOOD.replace("alpha", "beta"), "unknown key physics.friction.beta"),
    ("inertia = 0.003\n" + FRICTION, "missing physics.encoder_resolution"),
    (GOOD + "torque_noise = -1\n", "physics.torque_noise must not be negative"),
    (GOOD + "effects = ['cogging:amplitude=0.01']\n", "physics.effects"),
    (GOOD + "effects = ['teleportation:rate=3']\n", "physics.effects"),
    (GOOD + "effects = ['cogging:amplitude']\n", "expected key=value"),
    (GOOD + "effects = 'cogging'\n", "physics.effects must be a list"),
    (GOOD + "effects = ['inertia_error:factor=1.2']\n", "physics.inertia"),
    (GOOD + "gravity = [1]\n", "physics.gravity must be a list of two numbers"),
    ("inertia = 0.003\nfriction = 3\nencoder_resolution = 4.8e-5\n", "physics.friction must be a table"),
]


@pytest.mark.parametrize("physics,message", BAD_PHYSICS)
def test_bad_physics_one_line_naming_the_key(tmp_path, physics, message):
    p = tmp_path / "b.toml"
    p.write_text(JOINT + physics)
    with pytest.raises(InputError) as e:
        load_bench(p)
    assert message in str(e.value) and "joint 'w'" in str(e.value) and "\n" not in str(e.value)


def test_preset_and_physics_together_are_refused(tmp_path):
    p = tmp_path / "b.toml"
    p.write_text(JOINT.replace("id='w'", "id='w'\npreset='j1'") + GOOD)
    with pytest.raises(InputError, match="either preset or"):
        load_bench(p)


def test_physics_joint_loads_and_its_drive_simulates_it(tmp_path):
    """A valid table loads with its defaults filled; a friction that is not passive is a
    warning, not an error; the emulated drive's truth is the table (with its effects)."""
    from drivers.joint_config import complete_joint
    from virtual_drives.truth import joint_truth
    p = tmp_path / "b.toml"
    p.write_text(JOINT + GOOD + "effects = ['torque_offset:value=0.02']\n")
    cfg = load_bench(p)
    assert cfg.warnings == []
    j = cfg.joint("w")
    assert j["physics"]["torque_noise"] == 0.0 and j["physics"]["friction"]["Fc"] == 0.05
    truth = joint_truth(complete_joint(j))
    assert truth.spec.inertia == 0.003 and truth.spec.friction.Fs == 0.065
    assert truth.spec.position_limits == (-2.0, 2.0) and truth.spec.torque_limit == 0.5
    from bench import terms
    assert truth.extra[terms.OFFSET] == pytest.approx(0.02)
    # not passive (Section II): sigma2 / sigma1 = 0.02 < Fs / Fc - 1 = 0.3
    p.write_text(JOINT + GOOD.replace("sigma1 = 0.05", "sigma1 = 1.0"))
    cfg = load_bench(p)
    assert len(cfg.warnings) == 1 and "not passive" in cfg.warnings[0] and "physics.friction" in cfg.warnings[0]
