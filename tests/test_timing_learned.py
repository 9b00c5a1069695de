"""The learned predictor's rows of `dcmppi timing`: a model recipe resolved to its cached file."""

import json

from dcmppi.bench.crowds import recipes as models
from dcmppi.bench.timing import cases


def test_learned_rows_time_20_and_100_walkers_and_stay_out_of_the_fingerprint():
    rows = {(c.label, c.problem): c for c in cases.CASES}
    assert rows["dc-learned", "crowd-sf-20"].target_ms == 5.0
    assert rows["dc-learned", "crowd-sf"].target_ms == 20.0
    assert not any(c.params.get("prediction") == "learned" for c in cases.FINGERPRINT_CASES)


def test_with_model_passes_params_without_a_recipe_and_resolves_one(tmp_path, monkeypatch):
    assert cases.with_model(cases.CV) is cases.CV
    monkeypatch.setenv(models.MODELS_ENV, str(tmp_path))
    path = models.path_of("test", cases.LEARNED_MODEL)
    path.write_bytes(b"cached")  # a cached file is taken as it is, not trained again
    params = cases.with_model(cases.LEARNED)
    assert params["model"] == str(path) and params["prediction"] == "learned"
    assert cases.LEARNED["model"] is cases.LEARNED_MODEL  # the case's own table is untouched
    json.dumps(cases.LEARNED)  # the table prints as JSON (`dcmppi timing --json`)
