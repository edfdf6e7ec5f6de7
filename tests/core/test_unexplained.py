"""The unexplained verdict's words: what it tells a technician to look for."""
from bench.unexplained import assess


def _presliding_residual() -> tuple[dict, dict]:
    """A residual that depends on the travel since reversal and lives in presliding, as a
    static friction map's creep left it (independent simulator, static_eps, j1)."""
    final = {"whiteness": {"correlation_time_ratio": 1.3},
             "by_regime": {"presliding": {"rms": 40.0, "fraction": 0.2},
                           "sliding": {"rms": 10.0, "fraction": 0.8}},
             "by_direction": {"positive": {"rms": 20.0}, "negative": {"rms": 20.0}},
             "cross_correlation": {"torque_rate": 0.0, "acceleration": 0.0}}
    p = {"predicted_fraction": 0.86, "t": 26.0, "structured_rms": 24.0,
         "relies_on": ["travel_since_reversal", "velocity"],
         "importance": {"travel_since_reversal": 1.0, "velocity": 0.4}}
    return final, p


def test_a_presliding_residual_names_each_physics_once():
    final, p = _presliding_residual()
    out = assess(final, 25.0, 0.7, p, 1500.0)
    assert out["structured"] and out["concentrated_in"]["regime"] == "presliding"
    # the travel signal and the presliding regime point at the same physics: said once
    assert out["evidence"].count("Maxwell-slip") == 1, out["evidence"]
    assert out["evidence"].count("look for") == 1
