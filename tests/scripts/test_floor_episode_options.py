"""The options ``exploration_confidences.py`` and ``exploration_precision.py`` share
(:mod:`tomosim.commands.floor_episodes`): a bad one is refused, saying what to do."""

from __future__ import annotations

import pytest

from tests.support import load_script

SCRIPTS = ("exploration_confidences", "exploration_precision")
REFUSED = [
    (["--robots", "1"], "at least 2 robots"),
    (["--steps", "0"], "at least 1"),
    (["--policy", "bogus"], "choose one of: nearest, utility, assignment"),
    (["--worlds", "0", "-3"], "--worlds -3: seeds are whole numbers >= 0"),
    (["--seeds", "0", "-1"], "--seeds -1: seeds are whole numbers >= 0"),
    (["--team", "merger.confidence.acept=0.7"], "did you mean merger.confidence.accept"),
    (["--team", "merger.confidence.accept"], "--team takes NAME=VALUE"),
    (["--team", "confirm_at_once_confidence=1.5"], "confirm_at_once_confidence"),
    (["--team", "oracle_min_shared_m2=10"], "only the 'oracle' method uses it"),
]


@pytest.mark.parametrize("script", SCRIPTS)
@pytest.mark.parametrize(("argv", "said"), REFUSED)
def test_bad_arguments_are_refused_with_what_to_do(
    script: str, argv: list[str], said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as stopped:
        load_script(script).parse_args(argv)
    assert stopped.value.code == 2 and said in capsys.readouterr().err
