"""The diagnosis against a hidden INS heading bias in the independent world (tests/worlds).

Three 11-minute hovers hiding a heading bias of +9 degree, diagnosed in-process and judged
as the null campaign of tests/diagnose/test_independent_world.py (:func:`judged_draw`), in a
module of its own so that the two campaigns, each a module's fixture, may run on different
workers.
"""

from __future__ import annotations

import pytest

from dronewind.diagnose.experiments import Draw
from tests.diagnose.test_independent_world import judged_draw


@pytest.fixture(scope="module")
def heading_outcome(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """An INS heading bias of +9 degree, three flights, judged."""
    return judged_draw(Draw("heading_bias", {"deg": 9.0}, seed=7), tmp_path_factory.mktemp("heading"))


@pytest.mark.slow
def test_hidden_heading_bias_named_first(heading_outcome) -> None:
    """The heading bias is named (or shares an ambiguity set with a named cause)."""
    assert heading_outcome["detected"], heading_outcome


@pytest.mark.slow
def test_hidden_heading_bias_no_wrong_cause(heading_outcome) -> None:
    """No cause named that is neither the truth nor ambiguous with it."""
    assert not heading_outcome["wrong_cause"], heading_outcome


@pytest.mark.slow
def test_hidden_heading_bias_estimate(heading_outcome) -> None:
    """The estimate lies within 2 degree of +9 (experiments.TOLERANCES)."""
    assert heading_outcome["estimate_ok"], heading_outcome
