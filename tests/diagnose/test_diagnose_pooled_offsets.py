"""Model error common to several campaigns: the mean standardised residual per feature, tested over campaigns."""

from types import SimpleNamespace

import numpy as np
import pytest

from dronewind.diagnose.features import FEATURES
from dronewind.diagnose.fit_quality import residual_table
from dronewind.diagnose.pooled import pooled_offsets, residual_mean_z


def test_residual_mean_z_known_answer():
    """Two flights, rows written by the diagnosis' residual_table: (y - b) / sigma averaged over
    the flights where the feature is measured."""
    p = len(FEATURES)
    y = np.zeros((2, p))
    baseline = np.zeros((2, p))
    sigma = np.ones((2, p))
    y[:, 0] = [0.2, 0.6]
    sigma[:, 0] = [0.1, 0.2]           # z = 2 and 3
    y[1, 1] = np.nan                   # feature 1 measured on the first flight only: z = 0
    sigma[:, 2] = 0.0                  # no error: not standardised
    ev = SimpleNamespace(flights=["f1", "f2"], y=y, baseline=baseline, sigma=sigma,
                         conditions=[{"mean_speed_ms": 5.0}] * 2)
    out = residual_mean_z(residual_table(ev))
    assert out[FEATURES[0]] == pytest.approx(2.5)
    assert out[FEATURES[1]] == 0.0
    assert np.isnan(out[FEATURES[2]])
    moved = residual_mean_z(residual_table(ev, baseline + 0.1))
    assert moved[FEATURES[0]] == pytest.approx(((0.1 / 0.1) + (0.5 / 0.2)) / 2)


def test_pooled_offsets_known_answer():
    """Three campaigns at 1.0, 1.2, 0.8: mean 1, standard error 0.2/sqrt(3), t = 8.66 on 2 degrees of
    freedom (two-sided p = 0.0131); below 0.05/2 with two features tested, so significant."""
    camps = [{"a": 1.0, "b": 0.1}, {"a": 1.2, "b": -0.1}, {"a": 0.8, "b": 0.0}]
    out = pooled_offsets(camps, alpha=0.05, features=("a", "b"))
    assert out["a"]["mean_z"] == pytest.approx(1.0)
    assert out["a"]["se"] == pytest.approx(0.2 / np.sqrt(3))
    assert out["a"]["p_value"] == pytest.approx(0.01307, abs=2e-5)
    assert out["a"]["significant"] and out["a"]["n"] == 3
    assert out["b"]["mean_z"] == pytest.approx(0.0, abs=1e-12) and not out["b"]["significant"]
    # one campaign: no spread to test against
    one = pooled_offsets([{"a": 3.0}], features=("a",))
    assert one["a"]["mean_z"] == 3.0 and np.isnan(one["a"]["p_value"]) and not one["a"]["significant"]
    # a feature missing on a campaign is left out of that campaign only
    gap = pooled_offsets([{"a": 1.0}, {"a": np.nan}, {"a": 1.0}, {"a": 1.0}], features=("a",))
    assert gap["a"]["n"] == 3 and gap["a"]["se"] == 0.0 and gap["a"]["p_value"] == 0.0


def _campaigns(rng, n_campaigns, n_flights, offset, rho=0.3, tau=0.3):
    """Per-campaign mean z of 15 features: per-flight z N(0, 1) correlated rho between features, a
    campaign discrepancy N(0, tau^2) per feature, and ``offset`` added to the first feature."""
    p = len(FEATURES)
    corr = np.full((p, p), rho) + (1 - rho) * np.eye(p)
    chol = np.linalg.cholesky(corr)
    z = rng.standard_normal((n_campaigns, n_flights, p)) @ chol.T
    z = z + tau * rng.standard_normal((n_campaigns, 1, p))
    z[..., 0] += offset
    return [dict(zip(FEATURES, zc.mean(axis=0), strict=True)) for zc in z]


def test_pooled_offsets_false_alarm_rate_is_alpha():
    """No offset, correlated features and a discrepancy per campaign: the family-wise rate of any
    feature called significant over 800 sets of 24 four-flight campaigns is 0.05 (Bonferroni over 15
    features: 1 - (1 - 0.05/15)^15 = 0.049 for independent features, less with correlated ones);
    accepted within 0.02-0.07 (three binomial standard errors of 800 sets above, the
    correlation's conservatism below)."""
    rng = np.random.default_rng(20)
    hits = sum(any(v["significant"] for v in pooled_offsets(_campaigns(rng, 24, 4, 0.0)).values())
               for _ in range(800))
    assert 0.02 <= hits / 800 <= 0.07


def test_pooled_offsets_power():
    """An offset of 0.4 per flight on one feature over 24 four-flight campaigns (campaign means
    scatter by about 0.58): t about 3.4 against the Bonferroni threshold 3.3 on 23 degrees of freedom,
    found in about half the sets; over 48 campaigns (t about 4.8) in nearly all. Measured over
    300 sets each, accepted above 0.35 and 0.9."""
    rng = np.random.default_rng(21)
    found = {n: np.mean([pooled_offsets(_campaigns(rng, n, 4, 0.4))[FEATURES[0]]["significant"]
                         for _ in range(300)]) for n in (24, 48)}
    assert found[24] >= 0.35 and found[48] >= 0.9


# ---------------------------------------------------------------- diagnosis.json files, dronewind model-error
def _diagnosis(path, name, z_first, n_flights=3, unexplained=()):
    """A diagnosis.json whose baseline residual rows are written by the diagnosis' own residual_table:
    feature 0 at ``z_first`` on every flight, the others at 0 (sigma 1)."""
    import json

    from dronewind.diagnose.fit_quality import residual_table

    p = len(FEATURES)
    y = np.zeros((n_flights, p))
    y[:, 0] = z_first
    ev = SimpleNamespace(flights=[f"f{i}" for i in range(n_flights)], y=y, baseline=np.zeros((n_flights, p)),
                         sigma=np.ones((n_flights, p)), conditions=[{"mean_speed_ms": 5.0}] * n_flights)
    doc = {"campaign": name, "baseline": {"residuals": residual_table(ev)},
           "unexplained": [{"feature": f} for f in unexplained]}
    path.write_text(json.dumps(doc, default=float))
    return path


def test_read_and_pool_diagnoses(tmp_path):
    from dronewind.diagnose.pooled import offsets_table, pool_diagnoses, read_campaign
    from dronewind.diagnose.record import not_diagnosed_json

    files = [_diagnosis(tmp_path / f"d{k}.json", f"c{k}", z, unexplained=[FEATURES[0]] if k == 0 else [])
             for k, z in enumerate((3.0, 3.2, 2.8))]
    skipped = tmp_path / "skipped.json"
    import json

    skipped.write_text(json.dumps(not_diagnosed_json("c9", 1, {"f2": "hover too short"})))
    camps = [read_campaign(f) for f in [*files, skipped]]
    assert camps[0].mean_z[FEATURES[0]] == pytest.approx(3.0) and camps[0].n_flights == 3
    assert camps[0].unexplained == [FEATURES[0]] and camps[3].left_out
    result = pool_diagnoses(camps)
    first = result["features"][FEATURES[0]]
    # t = 3 / (0.2 / sqrt(3)) = 26 on 2 degrees of freedom: p = 0.0015, below 0.05 over the 15 features tested
    assert first["mean_z"] == pytest.approx(3.0) and first["p_value"] == pytest.approx(0.00148, abs=1e-4)
    assert first["significant"] and first["unexplained_in"] == ["c0"]
    assert not result["features"][FEATURES[1]]["significant"]
    assert [c["campaign"] for c in result["left_out"]] == ["c9"] and len(result["campaigns"]) == 3
    text = offsets_table(result)
    assert "model error common to 3 campaigns" in text and "left out: c9" in text


def test_pool_rejects_a_campaign_given_twice(tmp_path):
    import shutil

    from dronewind.diagnose.pooled import pool_diagnoses, read_campaign
    from dronewind.errors import InputError

    a = _diagnosis(tmp_path / "a.json", "camp", 1.0)
    b = tmp_path / "copy.json"
    shutil.copy(a, b)
    with pytest.raises(InputError, match="copy.json.*the same campaign given twice"):
        pool_diagnoses([read_campaign(a), read_campaign(b)])
    # the same name with other residuals is another campaign
    other = _diagnosis(tmp_path / "other.json", "camp", 0.5)
    assert len(pool_diagnoses([read_campaign(a), read_campaign(other)])["campaigns"]) == 2


@pytest.mark.parametrize("text, match", [
    ("{\n  \"campaign\": 1,\n  oops", r"bad\.json:3: not JSON"),
    ("[1, 2]", "not a diagnosis.json"),
    ('{"campaign": "c", "baseline": {}}', r"\[baseline.residuals\]: expected the list"),
    ('{"campaign": "c", "baseline": {"residuals": [{"feature": "ln_hf_u"}]}}', r"\[baseline.residuals\]\[0\]"),
    ('{"campaign": "c", "baseline": {"residuals": [{"feature": "ln_hf_u", "z": 1}, {"feature": "ln_hf_u", '
     '"z": "x"}]}}', r"\[baseline.residuals\]\[1\]: expected a row with 'feature' and a number"),
])
def test_read_campaign_names_the_file_and_what_is_wrong(tmp_path, text, match):
    from dronewind.diagnose.pooled import read_campaign
    from dronewind.errors import InputError

    bad = tmp_path / "bad.json"
    bad.write_text(text)
    with pytest.raises(InputError, match=match):
        read_campaign(bad)


def test_cli_model_error(tmp_path, capsys):
    import json

    from dronewind.cli import main

    files = [str(_diagnosis(tmp_path / f"d{k}.json", f"c{k}", z)) for k, z in enumerate((2.0, 1.5, 2.5, 1.8))]
    out = tmp_path / "me.json"
    assert main(["model-error", *files, "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "model error common to 4 campaigns" in text and f"written: {out}" in text
    doc = json.loads(out.read_text())
    assert doc["features"][FEATURES[0]]["significant"] and doc["features"]["sw_su_mast"]["mean_z"] == 0.0
    assert main(["model-error", files[0]]) == 0
    assert "one campaign: no spread" in capsys.readouterr().out
    assert main(["model-error", *files, "--alpha", "2"]) == 1
    assert "--alpha: 2: expected a rate between 0 and 1" in capsys.readouterr().err
    assert main(["model-error", str(tmp_path / "missing.json")]) == 1
    assert "missing.json" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["model-error", "--help"])
    assert "dronewind model-error results/*/diagnosis.json" in capsys.readouterr().out
