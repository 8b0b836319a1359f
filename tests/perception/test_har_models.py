import numpy as np
import pytest

from flexhrc.errors import FlexhrcError, FormatError, UnknownNameError
from flexhrc.perception.human import GMMGMRRecognizer, Preprocessor, gmr
from flexhrc.perception.human.evaluation import (
    SummaryFeatureBaseline,
    classification_report,
    cross_validate,
    volunteer_folds,
)


def test_gmr_single_gaussian_is_linear_regression():
    # One component: E[x|t] = mu_x + S_xt/S_tt (t - mu_t), Cov = S_xx - S_xt S_tx / S_tt.
    mean = np.array([[0.5, 1.0, -1.0]])
    cov = np.array([[[0.1, 0.05, 0.0], [0.05, 0.2, 0.0], [0.0, 0.0, 0.3]]])
    t = np.array([0.0, 0.5, 1.0])
    mu, c = gmr(np.array([1.0]), mean, cov, t)
    assert np.allclose(mu[:, 0], 1.0 + 0.5 * (t - 0.5))
    assert np.allclose(mu[:, 1], -1.0)
    assert np.allclose(c[:, 0, 0], 0.2 - 0.05**2 / 0.1)
    assert np.allclose(c[:, 1, 1], 0.3)


def test_gmr_matches_the_gmr_package():
    gmr_pkg = pytest.importorskip("gmr")
    rng = np.random.default_rng(0)
    from sklearn.mixture import GaussianMixture

    t = rng.uniform(0, 1, 400)
    x = np.column_stack([t, np.sin(3 * t) + 0.05 * rng.normal(size=400), t**2])
    gm = GaussianMixture(3, random_state=0).fit(x)
    q = np.linspace(0.05, 0.95, 7)
    mu, _ = gmr(gm.weights_, gm.means_, gm.covariances_, q)
    ref = gmr_pkg.GMM(3, gm.weights_, gm.means_, gm.covariances_)
    assert np.allclose(mu, ref.predict(np.array([0]), q[:, None]), atol=1e-8)


def test_streaming_features_equal_batch_features():
    x = np.random.default_rng(1).normal(0, 0.3, (200, 3)) + np.array([0.0, 0.0, -1.0])
    pre = Preprocessor()
    batch = pre.features(x)
    s = pre.stream()
    chunks = np.vstack([s.push(x[i : i + 7]) for i in range(0, 200, 7)])
    assert batch.shape == (200, 6)
    assert np.allclose(batch, chunks)
    # Gravity of a constant signal is that signal, body is zero.
    still = pre.features(np.tile([0.0, 0.0, -1.0], (50, 1)))
    assert np.allclose(still[:, :3], [0, 0, -1]) and np.allclose(still[:, 3:], 0)


def test_fit_predict_and_bic_selection(toy_model, toy_trials):
    assert toy_model.classes_ == ["pick_up", "put_down", "screw", "wave"]
    for m in toy_model.models_.values():
        assert all(1 <= k <= 3 for k in m.n_components)
        assert np.isfinite(m.threshold) and m.threshold > 0
    assert toy_model.predict(toy_trials) == [t.action for t in toy_trials]
    d = toy_model.distances(toy_trials[:4])
    assert d.shape == (4, 4)


def test_fit_from_arrays_and_labels(toy_trials):
    X = [t.samples for t in toy_trials]
    y = [t.action for t in toy_trials]
    rec = GMMGMRRecognizer(max_components=2).fit(X, y)
    assert rec.predict(X[:3]) == y[:3]
    with pytest.raises(ValueError, match="labels y are required"):
        GMMGMRRecognizer().fit(X)
    with pytest.raises(ValueError, match="3 labels"):
        GMMGMRRecognizer().fit(X, y[:3])


def test_deterministic_with_seed(toy_trials):
    a = GMMGMRRecognizer(max_components=2, random_state=3).fit(toy_trials)
    b = GMMGMRRecognizer(max_components=2, random_state=3).fit(toy_trials)
    assert np.array_equal(a.distances(toy_trials[:5]), b.distances(toy_trials[:5]))


@pytest.mark.parametrize(
    "kwargs",
    [{"max_components": 0}, {"threshold_quantile": 0}, {"threshold_scale": -1},
     {"min_std": -0.1}, {"duration_weight": -1}, {"max_points": 3}],
)  # fmt: skip
def test_parameter_validation(kwargs, toy_trials):
    with pytest.raises(ValueError):
        GMMGMRRecognizer(**kwargs).fit(toy_trials)


def test_unfitted_and_unknown_names(toy_model):
    with pytest.raises(FlexhrcError, match="not fitted"):
        GMMGMRRecognizer().predict([np.zeros((10, 3))])
    with pytest.raises(UnknownNameError, match="unknown action 'jump'"):
        toy_model.model("jump")


def test_save_load_roundtrip(tmp_path, toy_model, toy_trials):
    path = toy_model.save(tmp_path / "m.npz")
    loaded = GMMGMRRecognizer.load(path)
    assert loaded.classes_ == toy_model.classes_
    assert np.allclose(loaded.distances(toy_trials[:6]), toy_model.distances(toy_trials[:6]))
    (tmp_path / "junk.npz").write_bytes(b"not a model")
    with pytest.raises(FormatError, match="not a flexhrc HAR model"):
        GMMGMRRecognizer.load(tmp_path / "junk.npz")
    with pytest.raises(FlexhrcError, match="no such model"):
        GMMGMRRecognizer.load(tmp_path / "none.npz")


def test_report_metrics():
    rep = classification_report(["a", "a", "b", "b"], ["a", "b", "b", "b"])
    assert rep["accuracy"] == 0.75
    assert rep["confusion_matrix"] == [[1, 1], [0, 2]]
    assert rep["per_class"]["a"] == {"precision": 1.0, "recall": 0.5, "f1": 0.6667, "support": 2}
    assert rep["macro_f1"] == pytest.approx((0.6667 + 0.8) / 2, abs=1e-3)


def test_volunteer_folds_never_split_a_volunteer(toy_trials):
    folds = volunteer_folds(toy_trials)
    assert folds == [["v1"], ["v2"], ["v3"]]
    two = volunteer_folds(toy_trials, 2)
    assert sorted(v for f in two for v in f) == ["v1", "v2", "v3"]
    with pytest.raises(FlexhrcError, match="at least 2 volunteers"):
        volunteer_folds([t for t in toy_trials if t.volunteer == "v1"])


def test_cross_validation_gmr_and_baseline(toy_trials):
    y, p = cross_validate(toy_trials, lambda: GMMGMRRecognizer(max_components=2))
    assert classification_report(y, p)["accuracy"] >= 0.9
    y, p = cross_validate(toy_trials, lambda: SummaryFeatureBaseline(n_estimators=30))
    assert len(p) == len(toy_trials)


@pytest.mark.shared
@pytest.mark.slow
def test_hmp_by_volunteer_small(hmp_dir):
    """A quick volunteer split on three HMP actions (the full table is benchmarks/har_hmp.py)."""
    from flexhrc.perception.human import load_dataset

    trials = load_dataset(hmp_dir, actions=["drink_glass", "sitdown_chair", "walk"])
    train = [t for t in trials if t.volunteer != "m1"]
    test = [t for t in trials if t.volunteer == "m1"]
    rec = GMMGMRRecognizer(max_points=1000).fit(train)
    rep = classification_report([t.action for t in test], rec.predict(test))
    assert rep["accuracy"] >= 0.8


def test_fit_with_one_short_trial_per_action():
    rng = np.random.default_rng(0)
    down, left = np.array([0.0, 0.0, -1.0]), np.array([0.0, 1.0, 0.0])
    X = [rng.normal(0, 0.1, (12, 3)) + down, rng.normal(0, 0.1, (20, 3)) + left]
    rec = GMMGMRRecognizer().fit(X, ["a", "b"])
    assert rec.predict(X) == ["a", "b"]
