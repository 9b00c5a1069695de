"""Forecast evaluation: the metrics, the baselines, the predictors through their interface, the
protocol on ETH/UCY and the `predictor train` / `predictor eval` commands."""

import argparse
import json
import os
import pathlib

import numpy as np
import pytest
from scipy.stats import gaussian_kde

from dcmppi.bench.crowds import forecast_metrics, forecasters
from dcmppi.bench.crowds.evaluation import COLUMNS, evaluate, table
from dcmppi.cli import common
from dcmppi.cli import predictor as command
from dcmppi.control.predictors import learned
from dcmppi.tasks.replay import recordings

ROOT = pathlib.Path(__file__).resolve().parents[2]


def crowds():
    """The ETH/UCY folder ($DCMPPI_CROWDS, else ../shared/crowds), or skip saying why."""
    folder = pathlib.Path(os.environ.get(recordings.CROWDS_ENV) or ROOT.parent / "shared/crowds")
    if not (folder / "biwi_eth.txt").is_file():
        pytest.skip(f"the ETH/UCY files are absent ({folder}; set {recordings.CROWDS_ENV})")
    return folder


def walkers(tmp_path, name="walk.txt"):
    """A file of two people walking straight at 0.5 and 0.3 m per frame for 30 frames."""
    rows = [(10 * k, 1, 0.5 * k, 0.0) for k in range(30)]
    rows += [(10 * k, 2, 1.0, 4.0 - 0.3 * k) for k in range(30)]
    path = tmp_path / name
    np.savetxt(path, np.array(rows, dtype=float), delimiter="\t")
    return path


def test_constant_velocity_forecasts_a_straight_walker_exactly(tmp_path):
    w = recordings.windows(recordings.load(walkers(tmp_path), period=0.4))
    samples, point = forecasters.constant_velocity(w)
    scores = forecast_metrics.displacement(samples, w.future, point)
    assert len(w) == 2 * 11
    for column in ("ade", "fde", "min_ade", "min_fde"):
        np.testing.assert_allclose(scores[column], 0.0, atol=1e-12)
    noisy, centre = forecasters.heading_noise(w, np.random.default_rng(0))
    assert noisy.shape == (22, 20, 12, 2)
    np.testing.assert_array_equal(centre, point)  # the most likely: the noise-free path
    turn = np.arctan2(*(noisy[:, :, 0] - w.observed[:, None, -1])[..., ::-1].T).T
    straight = np.arctan2(*(point[:, 0] - w.observed[:, -1])[:, ::-1].T)
    spread = np.angle(np.exp(1j * (turn - straight[:, None])))
    assert np.degrees(spread.std()) == pytest.approx(25.0, rel=0.15)


def test_best_of_takes_the_best_sample_and_the_point_forecast_scores_alone():
    truth = np.zeros((1, 3, 2))
    samples = np.zeros((1, 2, 3, 2))
    samples[0, 0, :, 0] = [1.0, 1.0, 1.0]  # ADE 1, FDE 1
    samples[0, 1, :, 0] = [0.0, 0.0, 3.0]  # ADE 1, FDE 3
    samples[0, 1, :, 1] = [0.0, 0.0, 0.0]
    point = np.full((1, 3, 2), [0.0, 2.0])
    scores = forecast_metrics.displacement(samples, truth, point)
    assert scores["ade"][0] == pytest.approx(2.0) and scores["fde"][0] == pytest.approx(2.0)
    assert scores["min_ade"][0] == pytest.approx(1.0) and scores["min_fde"][0] == pytest.approx(1.0)


def test_the_kde_is_scipys_gaussian_kde_with_scotts_bandwidth(monkeypatch):
    rng = np.random.default_rng(3)
    points = rng.normal(size=(20, 2)) * [1.0, 2.0] + [0.5, 0.0]
    where = rng.normal(size=(6, 2))
    monkeypatch.setattr(forecast_metrics, "BANDWIDTH_FLOOR", 0.0)
    h = forecast_metrics.bandwidth(points[None])
    np.testing.assert_allclose(
        forecast_metrics.log_density(points[None], h, where[None])[0],
        gaussian_kde(points.T).logpdf(where.T),
    )


def test_coverage_of_a_calibrated_forecast_is_near_90_percent_and_sharper_is_likelier():
    rng = np.random.default_rng(0)
    M, P, T = 400, 20, 3
    truth = rng.normal(size=(M, T, 2))
    calibrated = rng.normal(size=(M, P, T, 2))
    scores = forecast_metrics.kde_scores(calibrated, truth)
    assert 0.85 < scores["coverage"].mean() < 0.95
    wide = forecast_metrics.kde_scores(3 * calibrated, truth)
    assert wide["coverage"].mean() > 0.99 and wide["nll"].mean() > scores["nll"].mean()
    narrow = forecast_metrics.kde_scores(0.3 * calibrated, truth)
    assert narrow["coverage"].mean() < 0.6 and narrow["nll"].mean() > scores["nll"].mean()


def test_the_project_predictors_forecast_through_their_interface(tmp_path):
    w = recordings.windows(recordings.load(walkers(tmp_path), period=0.4))
    model = tmp_path / "model.npz"
    learned.fit(w, seed=0).save(model)
    prior = np.array([1.0, 0.2, 0.0, 0.1])
    truth = w.future[:3]
    sub = type(w)(w.xy[:3], w.id[:3], w.frame[:3], w.source[:3], w.neighbours[:3], 8, 0.4)
    cases = [("cv", {"cv_std": 0.0}, 1e-9), ("learned", {"model": model}, 1e-9),
             ("ekf", {}, 0.2), ("social", {"reactive": False}, 0.3)]  # fmt: skip
    for name, params, bound in cases:
        f = forecasters.PredictorForecaster(name, 0.4, 12, prior, **params)
        samples, point = f(sub, np.random.default_rng(0))
        assert samples.shape == (3, 20, 12, 2)
        np.testing.assert_allclose(point, samples.mean(axis=1))
        assert forecast_metrics.displacement(samples, truth, point)["ade"].max() < bound, name
        if name == "learned":  # tracked by position, as the model sees the annotated tracks
            tracks = forecasters.learned_tracks(model)(sub)
            np.testing.assert_allclose(samples, tracks[0], atol=1e-12)


def test_the_population_gaussian_of_straight_walkers():
    xy = np.zeros((2, 20, 2))
    xy[0, :, 0] = 0.4 * np.arange(20)  # 1 m/s
    xy[1, :, 1] = 0.8 * np.arange(20)  # 2 m/s
    w = recordings.Windows(xy, np.arange(2), np.zeros(2), np.zeros(2, int), ((), ()), 8, 0.4)
    np.testing.assert_allclose(forecasters.obstacle_model(w), [1.5, 0.5, 0.0, 0.0], atol=1e-12)


@pytest.mark.slow
def test_the_standard_protocol_reproduces_constant_velocitys_published_figures():
    result = evaluate(["cv"], folder=crowds())
    average = result["rows"]["cv"]["average"]
    assert round(average["ade"], 2) == 0.53 and round(average["fde"], 2) == 1.15  # as published
    assert result["windows"]["eth"] == 364 and result["windows"]["univ"] > 20000
    assert "cv" in table(result) and "Social-STGCNN" in table(result)


@pytest.mark.slow
def test_evaluate_trains_leave_one_scene_out_models_and_scores_every_row():
    result = evaluate(
        ["cv-noise", "cv-sampled", "cv-crowds", "learned"], ["hotel"], crowds(), limit=60
    )
    rows = result["rows"]
    assert result["windows"] == {"hotel": 60}
    assert set(rows) == {"cv-noise", "cv-sampled", "cv-crowds", "learned"}
    # the preset's narrower spreads: the same draws, other sample sets
    assert rows["cv-crowds"]["hotel"]["nll"] != rows["cv-sampled"]["hotel"]["nll"]
    assert (
        len(result["models"]["hotel"]["sha256"]) == 64 and result["models"]["hotel"]["path"] is None
    )
    for row in rows.values():
        assert row["hotel"] == row["average"]
        assert set(row["hotel"]) == set(COLUMNS)
    assert rows["learned"]["hotel"]["nll"] < rows["cv-noise"]["hotel"]["nll"]
    with pytest.raises(ValueError, match="unknown scene 'zara4'"):
        evaluate(["cv"], ["zara4"], crowds())
    with pytest.raises(ValueError, match="unknown predictor 'cvv'"):
        evaluate(["cvv"], ["eth"], crowds())


def parse(argv):
    parser = argparse.ArgumentParser(prog="dcmppi")
    command.add_parser(parser.add_subparsers(dest="command", required=True), common.choices())
    return parser.parse_args(argv)


def test_train_command_writes_a_model_and_prints_its_hash(tmp_path, capsys):
    files = [str(walkers(tmp_path, "a.txt")), str(walkers(tmp_path, "b.txt"))]
    out = tmp_path / "m.npz"
    args = parse(["predictor", "train", "--data", *files, "--out", str(out), "--seed", "2"])
    assert args.func(args) == 0
    printed = capsys.readouterr().out
    assert learned.sha256(out) in printed and "44 windows of 2 files" in printed
    assert learned.load(out).seed == 2


def test_eval_command_prints_json(capsys):
    folder = str(crowds())
    args = parse(["predictor", "eval", "--predictors", "cv,cv-noise", "--scenes", "zara1",
                  "--limit", "30", "--folder", folder, "--json"])  # fmt: skip
    assert args.func(args) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["windows"] == {"zara1": 30} and set(result["rows"]) == {"cv", "cv-noise"}
    args = parse(["predictor", "eval", "--model", "nowhere", "--folder", folder])
    with pytest.raises(ValueError, match="expected SCENE=PATH"):
        args.func(args)
