"""How the diagnosis' work is cut into jobs (dronewind.diagnose.probes): seed parts and reference parts.

Known answers: the seed parts of a flight cover its seeds once, in order, in near-equal
contiguous shares; the bootstrap reference takes parts of about 10 CPU-s, within the setting.
"""

from __future__ import annotations

import pytest

from dronewind.diagnose.probes import BASELINE_PART, part_seeds, reference_jobs, seed_part


@pytest.mark.parametrize("n_seeds", [1, 2, 3, 30, 65, 90])
@pytest.mark.parametrize("n_parts", [1, 2, 3, 4])
def test_seed_parts_cover_the_seeds_once_in_order(n_seeds, n_parts):
    seeds = [101 * (k + 1) for k in range(n_seeds)]
    shares = [part_seeds(seed_part(k, n_parts), seeds) for k in range(1, n_parts + 1)]
    assert [s for share in shares for s in share] == seeds
    sizes = [len(share) for share in shares]
    assert max(sizes) - min(sizes) <= 1


def test_part_names():
    assert seed_part(2, 3) == "baseline:2/3"
    assert part_seeds(BASELINE_PART, [1, 2]) == [1, 2]
    assert part_seeds("w_gain", [1, 2]) is None
    with pytest.raises(ValueError, match="expected 1 <= k <= 3"):
        seed_part(4, 3)
    with pytest.raises(ValueError, match="expected 'baseline:k/n'"):
        part_seeds("baseline:two", [1, 2])


def test_reference_parts_of_about_twelve_cpu_seconds():
    """600 replicates at 0.0013 CPU-s per flight: 7.8 CPU-s on 10 flights (1 part), 15.6 on 20 (2),
    31.2 on 40 (3), none drawn on 1 flight (1 part); never more than the setting, never none."""
    assert reference_jobs(10, 600, 4) == 1
    assert reference_jobs(20, 600, 4) == 2
    assert reference_jobs(40, 600, 4) == 3
    assert reference_jobs(40, 600, 2) == 2
    assert reference_jobs(4, 600, 4) == 1
    assert reference_jobs(1, 600, 4) == 1
    assert reference_jobs(2, 50, 4) == 1
    assert reference_jobs(30, 5000, 100) == 17
