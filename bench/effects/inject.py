"""``bench simulate --effect NAME:key=value,...``: hidden physics for the virtual joints."""
from __future__ import annotations

from bench import terms
from bench.effects import get
from bench.errors import InputError


def parse_injection(text: str) -> tuple[str, dict]:
    name, _, rest = text.partition(":")
    kw = {}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        k, eq, v = item.partition("=")
        if not eq:
            raise InputError(f"--effect {text!r}: expected key=value, got {item!r}")
        kw[k.strip()] = v.strip()
    return name.strip(), kw


def parse_injections(texts, spec):
    """Returns (terms vector, declared/true inertia factor, Stribeck exponent or None,
    torque lag in s)."""
    ev = terms.empty()
    factor, delta, lag = 1.0, None, 0.0
    seen = set()
    for text in texts:
        name, kw = parse_injection(text)
        effect = get(name)
        if name in seen:
            raise InputError(f"--effect {name} given twice")
        seen.add(name)
        if name == "gravity" and spec.joint_type != "revolute":
            raise InputError("effect gravity applies to revolute joints only")
        changes = effect.inject(kw, ev, spec)
        factor *= changes.get("inertia_factor", 1.0)
        delta = changes.get("delta", delta)
        lag = changes.get("torque_lag", lag)
    return ev, factor, delta, lag
