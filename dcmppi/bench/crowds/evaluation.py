"""The standard forecasting protocol on ETH/UCY and its table.

Every file is read at 0.4 s a frame, biwi_eth included, as the prediction papers read it (their
figures are comparable only so; biwi_eth's true period is 0.667 s). Leave one scene out: a
scene's files are the test set, every other file (the training-only ones too) trains the
learned model and fits the population Gaussian of "prior" and "ekf". Every window of 8 observed
and 12 predicted consecutive frames of every person is forecast
(dcmppi.tasks.replay.recordings.windows) with 20 samples; forecast_metrics.py says what each
column measures. A five-scene average is the mean of the scenes' means, as the papers average.
"""

import pathlib
import tempfile

import numpy as np

from dcmppi.bench.crowds import forecast_metrics, forecasters
from dcmppi.control.defaults import PRESETS
from dcmppi.control.predictors import learned, predictor_class
from dcmppi.tasks.replay import recordings

OBS, PRED = 8, 12
PERIOD = recordings.PERIOD
BASELINES = {"cv": forecasters.constant_velocity, "cv-noise": forecasters.heading_noise}
# rows that are the project's predictors under another name, (predictor, its parameters): `cv`
# is the field's one-sample baseline, so the `cv` predictor (Gaussian velocity errors) is the row
# cv-sampled; cv-still is it with the crowds preset's spread for people standing, cv-crowds with
# both of its spreads
ALIASES = {
    "cv-sampled": ("cv", {}),
    "cv-still": ("cv", {"cv_std_still": PRESETS["crowds"]["cv_std_still"]}),
    "cv-crowds": ("cv", {n: PRESETS["crowds"][n] for n in ("cv_std", "cv_std_still")}),
}
ROWS = (
    "cv", "cv-noise", "cv-sampled", "cv-still", "cv-crowds", "prior", "ekf", "social",
    "learned-tracks", "learned",
)  # fmt: skip
LEARNED = ("learned", "learned-tracks")  # the rows of a learned model
COLUMNS = ("ade", "fde", "min_ade", "min_fde", "nll", "coverage")
# Five-scene averages from the papers (../shared/crowds/README.md): most likely, best of 20
PUBLISHED = {
    "constant velocity (Schöller et al. 2020)": {"ade": 0.53, "fde": 1.15},
    "cv, 25 deg heading noise (Schöller et al. 2020)": {"min_ade": 0.42, "min_fde": 0.86},
    "Social-GAN (model zoo)": {"min_ade": 0.48, "min_fde": 0.96},
    "Social-STGCNN": {"min_ade": 0.44, "min_fde": 0.75},
    "Trajectron++ (after its preprocessing fix)": {"min_ade": 0.32, "min_fde": 0.55},
}


def evaluate(
    predictors=ROWS,
    scenes=tuple(recordings.SCENES),
    folder=None,
    models=None,
    seed=0,
    limit=None,
    period=PERIOD,
    frame_step=None,
) -> dict:
    """Forecast every window of each test scene with each predictor (module docstring).

    predictors: row names: "cv", "cv-noise", "cv-sampled", "cv-still", "cv-crowds" (ALIASES),
      "learned-tracks" (the learned model on the annotated tracks, forecasters.learned_tracks),
      or a registered predictor's name
      ("prior", "ekf", "social", "learned", ...), run through its Predictor interface.
    models: {scene: path} of the learned models; a scene without one gets a model trained here
      on its training files with `seed` (a temporary file).
    limit: at most this many windows per scene, evenly spaced (None: every window).
    period, frame_step: how every file is read (recordings.load): seconds between annotated
      frames (PERIOD, as the papers read them) and video frames between them (None: inferred).
    Returns {"protocol", "windows": {scene: M}, "models": {scene: {path, sha256, shrink}},
      "rows": {row: {scene: {column: mean}, "average": {column: mean}}}, "published"}.
    """
    folder = recordings.crowds_folder(folder)
    _check(predictors, scenes, limit)
    rows = {name: {} for name in predictors}
    counts, used = {}, {}
    reading = {"period": period, "frame_step": frame_step}
    with tempfile.TemporaryDirectory() as scratch:
        for scene in scenes:
            train = recordings.windows(
                [recordings.load(f, folder, **reading) for f in recordings.train_files(scene)],
                OBS,
                PRED,
            )
            test = _subset(
                recordings.windows(recordings.scene(scene, folder, **reading), OBS, PRED), limit
            )
            counts[scene] = len(test)
            model = None
            if set(LEARNED) & set(predictors):
                model = (models or {}).get(scene)
                used[scene] = _provenance(model or _train(train, seed, scratch, scene), model)
                model = model or used[scene].pop("trained")
            for name in predictors:
                rng = np.random.default_rng(seed)
                samples, point = forecaster(name, train, model)(test, rng)
                rows[name][scene] = score(samples, test.future, point, seed)
    for by_scene in rows.values():
        by_scene["average"] = {c: float(np.mean([by_scene[s][c] for s in scenes])) for c in COLUMNS}
    return {
        "protocol": _protocol(period, seed, limit),
        "windows": counts,
        "models": used,
        "rows": rows,
        "published": PUBLISHED,
    }


def _protocol(period, seed, limit) -> dict:
    """The settings an evaluation's figures depend on."""
    return {
        "obs": OBS,
        "pred": PRED,
        "period": period,
        "samples": forecasters.SAMPLES,
        "seed": seed,
        "limit": limit,
        "bandwidth_floor": forecast_metrics.BANDWIDTH_FLOOR,
        "hdr_mass": forecast_metrics.HDR_MASS,
    }


def _check(predictors, scenes, limit) -> None:
    """One ValueError for a bad limit, an unknown scene or an unknown predictor."""
    if limit is not None and (isinstance(limit, bool) or not isinstance(limit, int) or limit < 1):
        raise ValueError(f"limit must be a count >= 1; got {limit!r}")
    for scene in scenes:
        recordings.train_files(scene)
    for name in predictors:
        if name not in BASELINES and name != "learned-tracks":
            predictor_class(ALIASES.get(name, (name,))[0])


def forecaster(name, train, model=None):
    """The forecaster of row `name` (windows, rng -> samples, point); `train`: the training
    windows (the population Gaussian); model: the learned model's path."""
    if name in BASELINES:
        return BASELINES[name]
    if name == "learned-tracks":
        return forecasters.learned_tracks(model)
    predictor, params = ALIASES.get(name, (name, {}))
    params = {"model": str(model)} if predictor == "learned" else params
    return forecasters.PredictorForecaster(
        predictor, train.period, PRED, forecasters.obstacle_model(train), **params
    )


def score(samples, truth, point, seed=0) -> dict:
    """{column: mean over windows} of samples (M, P, pred, 2) against truth (M, pred, 2)."""
    scores = {
        **forecast_metrics.displacement(samples, truth, point),
        **forecast_metrics.kde_scores(samples, truth, seed),
    }
    return {c: float(scores[c].mean()) for c in COLUMNS}


def _train(windows, seed, folder, scene) -> pathlib.Path:
    """A learned model of `windows` saved in `folder`."""
    path = pathlib.Path(folder) / f"learned-{scene}.npz"
    learned.fit(windows, seed).save(path)
    return path


def _provenance(path, given) -> dict:
    """{path, sha256, shrink} of a model; path None (and "trained": the temporary file) for a
    model trained here."""
    entry = {"path": str(given) if given else None, "sha256": learned.sha256(path)}
    entry["shrink"] = learned.load(path).shrink
    return entry if given else {**entry, "trained": path}


def _subset(windows, limit):
    """At most `limit` of the windows, evenly spaced (all when limit is None)."""
    if limit is None or limit >= len(windows):
        return windows
    keep = np.linspace(0, len(windows) - 1, limit).round().astype(int)
    return type(windows)(
        windows.xy[keep],
        windows.id[keep],
        windows.frame[keep],
        windows.source[keep],
        tuple(windows.neighbours[i] for i in keep),
        windows.obs,
        windows.period,
        windows.names,
    )


def table(result) -> str:
    """The evaluation as text: five-scene averages, then per scene, then the papers' figures."""
    scenes = list(result["windows"])
    lines = [
        f"ETH/UCY forecasts: observe {result['protocol']['obs']}, predict "
        f"{result['protocol']['pred']} frames of {result['protocol']['period']} s, leave one "
        f"scene out, {result['protocol']['samples']} samples; windows: "
        + ", ".join(f"{s} {n}" for s, n in result["windows"].items()),
        "",
        f"{'average':<15} {'ADE':>6} {'FDE':>6} {'minADE':>7} {'minFDE':>7} {'NLL':>6} "
        f"{'cov90':>6}",
    ]
    for name, row in result["rows"].items():
        a = row["average"]
        lines.append(
            f"{name:<15} {a['ade']:6.2f} {a['fde']:6.2f} {a['min_ade']:7.2f} {a['min_fde']:7.2f} "
            f"{a['nll']:6.2f} {a['coverage']:6.2f}"
        )
    lines += ["", "per scene: minADE/minFDE (best of 20), ADE/FDE (most likely), NLL, cov90"]
    lines.append(f"{'':<15} " + " ".join(f"{s:>24}" for s in scenes))
    for name, row in result["rows"].items():
        cells = [
            f"{row[s]['min_ade']:.2f}/{row[s]['min_fde']:.2f} {row[s]['ade']:.2f}/"
            f"{row[s]['fde']:.2f} {row[s]['nll']:5.2f} {row[s]['coverage']:.2f}"
            for s in scenes
        ]
        lines.append(f"{name:<15} " + " ".join(f"{c:>24}" for c in cells))
    lines += ["", "published five-scene averages (ADE/FDE most likely; minADE/minFDE best of 20)"]
    for source, figures in result["published"].items():
        text = ", ".join(f"{k} {v:.2f}" for k, v in figures.items())
        lines.append(f"  {source}: {text}")
    return "\n".join(lines)
