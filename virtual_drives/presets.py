"""Virtual joints with the friction of the paper's Tables I and II.

Friction parameters are the paper's.  Inertias, workspaces, encoders and noise are not in
the paper; they are plausible values for the machines it describes:
- micromanipulator (Table I): a direct-drive linear stage carrying a direct-drive rotary
  joint; 0.5 um linear scale, 2^17-count rotary encoder; the rotary joint may turn fast
  (its Stribeck velocity 1/alpha = 10 rad/s is only reached well above the paper's 2.5 rad/s);
- macromanipulator (Table II): geared joints (1:489, 1:600, 1:310, 1:324) with 8000-count
  motor encoders, heavy links, speeds under 0.4 rad/s; joints 2 and 4 (the Pi-joints)
  carry gravity, joints 1 and 3 turn about vertical axes.
``excitation`` is an (amplitude, frequency) that reaches sliding inside the workspace;
the procedure engine searches its own.

``load_fraction`` is the share of M_jj beyond the gear (backlash and gear compliance sit
between motor and load; see ``bench.terms``).  Geared joints: the motor's reflected inertia
J_m N^2 is sized by the usual inertia-matching rule (load-to-motor ratio 1 to 3 at the
joint), so the load carries 50-75 %: 0.5 for the lighter vertical-axis joints, 0.6 for the
Pi-joints carrying the arm.  Direct drives have no gear; a backlash or compliance there is
a coupling to a payload or a tool, a third of the inertia.
"""
from __future__ import annotations

import math

from bench.lugre import LuGreParams
from virtual_drives.joint import JointSpec


def _geared(ratio: float, counts: int = 8000) -> float:
    return 2.0 * math.pi / (counts * ratio)


PRESETS: dict[str, JointSpec] = {
    "linear": JointSpec(
        name="linear", joint_type="prismatic", inertia=3.0,
        friction=LuGreParams(Fc=2.4, Fs=4.9, alpha=6.7, sigma0=1e4, sigma1=500.0, sigma2=11.1),
        position_limits=(-0.15, 0.15), velocity_limit=1.98, torque_limit=40.0,
        encoder_resolution=0.5e-6, torque_noise=0.02, excitation=(13.0, 1.0),
        description="Table I linear motor: direct-drive linear stage",
        load_fraction=0.3),
    "rotary": JointSpec(
        name="rotary", joint_type="revolute", inertia=0.005,
        friction=LuGreParams(Fc=0.12, Fs=0.15, alpha=0.1, sigma0=100.0, sigma1=2.0, sigma2=0.075),
        position_limits=(-2 * math.pi, 2 * math.pi), velocity_limit=60.0, torque_limit=5.0,
        encoder_resolution=2 * math.pi / 2**17, torque_noise=0.001, excitation=(3.2, 2.0),
        description="Table I rotary motor: direct-drive revolute joint",
        load_fraction=0.3),
    "j1": JointSpec(
        name="j1", joint_type="revolute", inertia=250.0,
        friction=LuGreParams(Fc=1500.0, Fs=1614.0, alpha=18.0, sigma0=1e6, sigma1=8900.0, sigma2=11262.0),
        position_limits=(-2.5, 2.5), velocity_limit=0.4, torque_limit=8000.0,
        encoder_resolution=_geared(489.14), torque_noise=5.0, excitation=(5500.0, 0.25),
        description="Table II joint 1: vertical-axis revolute, gear 1:489.14",
        load_fraction=0.5, gear_ratio=489.14),
    "j2": JointSpec(
        name="j2", joint_type="revolute", inertia=180.0,
        friction=LuGreParams(Fc=1380.0, Fs=1546.0, alpha=11.0, sigma0=1e6, sigma1=8500.0, sigma2=10914.0),
        position_limits=(-1.0, 1.0), velocity_limit=0.4, torque_limit=8000.0,
        encoder_resolution=_geared(600.0), torque_noise=5.0, gravity=(0.0, 2400.0),
        excitation=(5200.0, 0.3),
        description="Table II joint 2: Pi-joint (gravity), gear 1:600",
        load_fraction=0.6, gear_ratio=600.0),
    "j3": JointSpec(
        name="j3", joint_type="revolute", inertia=30.0,
        friction=LuGreParams(Fc=105.0, Fs=116.0, alpha=5.0, sigma0=1e5, sigma1=800.0, sigma2=1878.0),
        position_limits=(-2.5, 2.5), velocity_limit=0.4, torque_limit=1500.0,
        encoder_resolution=_geared(310.0), torque_noise=0.4, excitation=(800.0, 0.25),
        description="Table II joint 3: vertical-axis revolute, gear 1:310",
        load_fraction=0.5, gear_ratio=310.0),
    "j4": JointSpec(
        name="j4", joint_type="revolute", inertia=45.0,
        friction=LuGreParams(Fc=564.0, Fs=610.0, alpha=10.0, sigma0=1e5, sigma1=800.0, sigma2=3450.0),
        position_limits=(-1.0, 1.0), velocity_limit=0.4, torque_limit=3000.0,
        encoder_resolution=_geared(324.2), torque_noise=2.0, gravity=(0.0, 900.0),
        excitation=(1900.0, 0.3),
        description="Table II joint 4: Pi-joint (gravity), gear 1:324.2",
        load_fraction=0.6, gear_ratio=324.2),
}


def preset(name: str) -> JointSpec:
    from bench.errors import InputError
    try:
        return PRESETS[name]
    except KeyError:
        raise InputError(f"unknown joint preset {name!r}; known: {', '.join(PRESETS)}") from None
