"""The groups `make test` hands pytest-xdist: tests sharing a fixture of the suite run on one worker.

tests/conftest.py groups the session's tests (``_fixture_groups``) and its scheduler puts a
group on one worker. Were the grouping to break, each worker would make the small campaign's
workflow run again: the suite would still pass, only slower, so it is checked here.
"""

from __future__ import annotations

import pytest

from tests.conftest import _fixture_groups


def test_tests_sharing_the_small_campaign_run_form_one_group(request):
    items = request.session.items
    groups = _fixture_groups(items)
    users = [k for k, item in enumerate(items) if "small_campaign_run" in item.fixturenames]
    if not users:
        pytest.skip("no test of the small campaign's run is in this session")
    names = {groups[k] for k in users}
    assert len(names) == 1 and names.pop().startswith("session:"), names


def test_a_module_fixture_groups_its_module_and_plain_tests_stay_alone(request):
    items = request.session.items
    groups = _fixture_groups(items)
    mine = [k for k, item in enumerate(items) if item.path.name == "test_xdist_groups.py"]
    assert mine and all(k not in groups for k in mine)  # no module or session fixture here
    figures = [k for k, item in enumerate(items) if item.path.name == "test_figures.py"
               and "products" in item.fixturenames]
    if figures:  # the module-scoped products of test_figures: one group for the module
        assert {groups[k] for k in figures} == {"module:test_figures.py"}
