"""Which contender a diagnosis round adds (bench.rounds): the criterion decides, unless the
contenders lie within CRITERION_TIE of each other, where the lower held-out error does, and the
step says it was a close call."""
from types import SimpleNamespace

from bench.rounds import CRITERION_TIE, close_calls, close_text, round_winner


def _result(criterion, effect, rms):
    return (criterion, SimpleNamespace(effect=effect), SimpleNamespace(rms=rms))


def test_the_criterion_decides_when_the_gap_is_clear():
    results = [_result(-80.0, "inertia_error", 0.15), _result(-80.0 + CRITERION_TIE + 0.5, "joint_flexibility", 0.12)]
    winner = round_winner(results)
    assert winner[1].effect == "inertia_error"
    assert close_calls(results, winner[1]) == []
    assert close_text([], 0.15) == ""


def test_within_the_tie_the_lower_held_out_error_wins_and_the_runner_up_is_named():
    # 5542's round: the spring 0.1 behind on the criterion, 19 % lower held out
    results = [_result(-76.8, "inertia_error", 0.149), _result(-76.7, "joint_flexibility", 0.120),
               _result(-72.4, "gravity", 0.154)]
    winner = round_winner(results)
    assert winner[1].effect == "joint_flexibility"
    close = close_calls(results, winner[1])
    assert close == [("inertia_error", 0.149)]
    text = close_text(close, winner[2].rms)
    assert "a close call: inertia_error (0.149)" in text and "(0.12)" in text


def test_a_lone_contender_is_no_close_call():
    results = [_result(10.0, "cogging", 1.0)]
    winner = round_winner(results)
    assert winner is results[0] and close_calls(results, winner[1]) == []
