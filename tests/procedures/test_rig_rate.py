"""The rig's cycling rules: commanded joints every period, resting held joints once per
idle_period in lock-step, moving ones every period, everything every period in real time."""
import dataclasses

from procedures.config import load_bench
from procedures.rig import Rig

from proc_helpers import make_rig


def cycles(rig):
    return {j: rig.drives[j].cycles for j in rig.ids}


def delta(rig, before):
    return {j: n - before[j] for j, n in cycles(rig).items()}


def test_resting_held_joints_are_cycled_once_per_idle_period():
    cfg = load_bench("macro4")
    assert cfg.clock == "lockstep" and round(cfg.idle_period / cfg.control_period) == 10
    rig = make_rig(cfg, seed=11)
    for _ in range(50):
        rig.step()
    c0 = cycles(rig)
    for _ in range(200):
        rig.step({"j3": rig.hold_torque("j3")})
    d = delta(rig, c0)
    assert d["j3"] == 200
    assert all(19 <= d[j] <= 21 for j in ("j1", "j2", "j4")), d
    # j1 pushed past breakaway, then only held: cycled every period while it moves
    for _ in range(150):
        rig.step({"j1": 1700.0})
    assert abs(rig.samples["j1"].velocity) > 0.01       # 25x the "at rest" speed
    rig.hold_here()
    c1 = cycles(rig)
    for _ in range(5):
        rig.step()
    assert delta(rig, c1)["j1"] == 5
    rig.settle()
    assert all(abs(s.velocity) < 1e-3 for s in rig.samples.values())
    rig.park()


def test_realtime_clock_cycles_every_joint_every_period():
    cfg = dataclasses.replace(load_bench("macro4"), clock="realtime")
    rig = Rig(cfg, {})
    assert rig.idle_every == 1


def test_commanded_joint_goes_first_in_the_round():
    cfg = load_bench("macro4")
    rig = make_rig(cfg, seed=23)
    order = []
    for jid, d in rig.drives.items():
        orig = d.cycle
        d.cycle = lambda tau, jid=jid, orig=orig: (order.append(jid), orig(tau))[1]
    rig._last_cycle.clear()          # every joint due this round
    rig.step({"j4": rig.hold_torque("j4")})
    assert order == ["j4", "j1", "j2", "j3"]
    rig.park()
