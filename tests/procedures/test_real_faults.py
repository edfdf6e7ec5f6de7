"""Safety through the real stacks: a drive fault mid-trial (emulated ODrive axis error /
CANopen EMCY) quick-stops and disables every drive of the bench and fails the procedure."""
import pytest

from procedures.events import ProcedureFailed
from procedures.excitation import search

from proc_helpers import bench_with, real_rig


@pytest.mark.parametrize("victim,fault,args", [("j3", "fault", {"code": 0x40}), ("j1", "emcy", {})])
def test_fault_mid_trial_stops_every_drive(victim, fault, args):
    cfg = bench_with("macro4", ["j1", "j3"])
    with real_rig(cfg, seed=11) as rig:
        handle = rig.virtual_bench.drive(victim)
        drive = rig.drives[victim]
        n = {"cycles": 0}
        cycle = drive.cycle

        def faulty_cycle(tau):
            n["cycles"] += 1
            if n["cycles"] == 400:          # well inside the first trial
                handle.inject(fault, **args)
            return cycle(tau)
        drive.cycle = faulty_cycle
        with pytest.raises(ProcedureFailed, match=f"{victim}: drive error"):
            search(rig, victim)
        assert n["cycles"] >= 400
        for jid in cfg.ids:
            snap = rig.virtual_bench.drive(jid).snapshot()
            assert not snap["powered"], (jid, snap)           # nothing left under torque
        assert rig.virtual_bench.drive(victim).snapshot()["state"] == "fault"
        rig.parked = True        # the drives are off; closing must not try to move them
