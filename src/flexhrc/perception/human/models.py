"""GMM/GMR models of human motion primitives (Bruno, Mastrogiovanni, Sgorbissa et al.).

The approach of Bruno et al. (CASE 2012, "Human motion modelling and recognition: a
computational approach"; ICRA 2013), used by FlexHRC+ (paper 000, section III), in four steps:

1. **Pre-processing** — the wrist signal is split into gravity and body components
   (:mod:`.preprocessing`); every example trial of an action is time-normalised to the model
   length ``L`` (the median trial length of that action).
2. **Gaussian Mixture Model** — per action and per feature group (gravity, body) a GMM is fitted
   over the joint space (time, features) of all example trials with scikit-learn's
   ``GaussianMixture``; the number of components is the one with the lowest BIC.
3. **Gaussian Mixture Regression** — conditioning the GMM on time gives, for each of the ``L``
   time steps, the *expected* feature vector and its covariance: the action's template.
4. **Matching** — a window of signal, time-normalised to ``L``, is compared with the template
   by the mean Mahalanobis distance of its samples to the expected trajectory. An action is
   recognised when its distance falls below the model's threshold (a quantile of the distances of
   its own training trials, scaled); the best match is the model with the lowest
   threshold-normalised distance.

Models save to a single ``.npz`` file (arrays + JSON metadata, no pickle).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np

from flexhrc.errors import FlexhrcError, FormatError, UnknownNameError
from flexhrc.perception._deps import require
from flexhrc.perception.human.dataset import Trial
from flexhrc.perception.human.preprocessing import Preprocessor, resample

FORMAT_VERSION = 1

#: Feature groups modelled by separate GMMs: gravity (0..2) and body (3..5), as in Bruno et al.
DEFAULT_GROUPS: tuple[tuple[int, ...], ...] = ((0, 1, 2), (3, 4, 5))

#: What a model file keeps of each action model (with its arrays), in the order of the file's
#: metadata; of the recogniser it keeps every parameter.
_SAVED_MODEL = ("name", "length", "threshold", "n_components", "log_length_mean", "log_length_std")


def gmr(
    weights: np.ndarray, means: np.ndarray, covariances: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian Mixture Regression of the outputs on the first (time) dimension.

    For a GMM over ``(t, x)`` with components ``k`` it returns, at each query time, the
    conditional mean ``E[x | t] = Σ_k h_k(t) μ_k(t)`` and covariance
    ``Σ_k h_k(t) (Σ_k^{x|t} + μ_k(t) μ_k(t)^T) - E[x|t] E[x|t]^T`` where ``h_k`` are the
    responsibilities of the components for ``t``, ``μ_k(t) = μ_x + Σ_xt / σ_tt (t - μ_t)`` and
    ``Σ_k^{x|t} = Σ_xx - Σ_xt Σ_tx / σ_tt`` (Calinon's formulation, 1-D input).
    """
    t = np.asarray(t, dtype=float)
    mu_t = means[:, 0]  # (K,)
    mu_x = means[:, 1:]  # (K, D)
    s_tt = covariances[:, 0, 0]  # (K,)
    s_xt = covariances[:, 1:, 0]  # (K, D)
    s_xx = covariances[:, 1:, 1:]  # (K, D, D)
    # Responsibilities h_k(t) ∝ π_k N(t; μ_t, σ_tt), computed in log space for stability.
    diff = t[:, None] - mu_t[None, :]  # (L, K)
    logp = np.log(weights)[None, :] - 0.5 * (diff**2 / s_tt + np.log(2 * np.pi * s_tt))
    logp -= logp.max(axis=1, keepdims=True)
    h = np.exp(logp)
    h /= h.sum(axis=1, keepdims=True)
    gain = s_xt / s_tt[:, None]  # (K, D)
    mu_k = mu_x[None, :, :] + diff[:, :, None] * gain[None, :, :]  # (L, K, D)
    cond = s_xx - np.einsum("kd,ke->kde", s_xt, s_xt) / s_tt[:, None, None]  # (K, D, D)
    mean = np.einsum("lk,lkd->ld", h, mu_k)
    second = np.einsum("lk,kde->lde", h, cond) + np.einsum("lk,lkd,lke->lde", h, mu_k, mu_k)
    cov = second - np.einsum("ld,le->lde", mean, mean)
    return mean, cov


@dataclass
class ActionModel:
    """The GMR template of one action: per feature group, expected trajectory and covariance."""

    name: str
    length: int
    means: list[np.ndarray]  # per group, (L, d)
    covariances: list[np.ndarray]  # per group, (L, d, d)
    n_components: list[int]
    threshold: float = np.inf
    groups: tuple[tuple[int, ...], ...] = DEFAULT_GROUPS
    log_length_mean: float = 0.0
    log_length_std: float = 1.0
    duration_weight: float = 0.0
    _precisions: list[np.ndarray] = field(default_factory=list, repr=False, compare=False)

    def __post_init__(self) -> None:
        self._precisions = [np.linalg.inv(c) for c in self.covariances]

    @property
    def n_features(self) -> int:
        return sum(len(g) for g in self.groups)

    def expected(self) -> tuple[np.ndarray, np.ndarray]:
        """Full expected feature trajectory ``(L, F)`` and block-diagonal covariance."""
        mean = np.zeros((self.length, self.n_features))
        cov = np.zeros((self.length, self.n_features, self.n_features))
        for g, mu, c in zip(self.groups, self.means, self.covariances, strict=True):
            idx = np.asarray(g)
            mean[:, idx] = mu
            cov[:, idx[:, None], idx[None, :]] = c
        return mean, cov

    def distance(self, features: np.ndarray) -> float:
        """Template distance plus the duration term: what recognition thresholds."""
        return self.template_distance(features) + self.duration_weight * self.duration_distance(
            len(features)
        )

    def duration_distance(self, n_samples: int) -> float:
        """Half the squared z-score of ``log(n_samples)`` under the training durations."""
        z = (np.log(max(n_samples, 1)) - self.log_length_mean) / self.log_length_std
        return 0.5 * float(z * z)

    def template_distance(self, features: np.ndarray) -> float:
        """Mean Mahalanobis distance of a feature window (any length, time-normalised to L)."""
        x = resample(features, self.length)
        total = 0.0
        for g, mu, prec in zip(self.groups, self.means, self._precisions, strict=True):
            d = x[:, list(g)] - mu
            m2 = np.einsum("ld,lde,le->l", d, prec, d)
            total += float(np.mean(np.sqrt(np.maximum(m2, 0.0) / len(g))))
        return total / len(self.groups)


@dataclass(eq=False)
class GMMGMRRecognizer:
    """Human motion primitive recogniser: one GMM/GMR template per action.

    Parameters follow scikit-learn conventions and are validated in :meth:`fit`:

    max_components:
        largest number of Gaussian components tried per model (chosen by BIC from 1..max).
    threshold_quantile, threshold_scale:
        an action's threshold is ``scale × quantile`` of its training trials' distances.
    min_std:
        floor (g) added to the GMR variances — the HMP sensor has a 0.048 g quantum, and a
        template must not be more confident than the sensor.
    max_points:
        (time, feature) points used to fit each GMM (random subset, for speed).
    preprocessor:
        the gravity/body split; its ``rate_hz`` must match the data.
    duration_weight:
        weight of the duration term. Time normalisation discards how long a motion lasts, yet
        duration separates e.g. climbing a few stairs from a long walk; the distance of a window
        adds ``duration_weight × ½ z²`` where ``z`` is the z-score of its log-length under the
        training trials (a Gaussian prior on log-duration). 0 gives the plain template match.
    random_state:
        seed of the GMM initialisation and sub-sampling (results are deterministic).
    """

    max_components: int = 4
    threshold_quantile: float = 0.95
    threshold_scale: float = 2.0
    min_std: float = 0.01
    max_points: int = 2000
    duration_weight: float = 0.1
    preprocessor: Preprocessor = field(default_factory=Preprocessor)
    groups: tuple[tuple[int, ...], ...] = DEFAULT_GROUPS
    random_state: int = 0
    models_: dict[str, ActionModel] = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.preprocessor is None:  # accepted, as before: the default pre-processing
            self.preprocessor = Preprocessor()

    # ----------------------------------------------------------------------------------- fit
    def _validate(self) -> None:
        if not isinstance(self.max_components, int) or self.max_components < 1:
            raise ValueError(f"max_components must be an int >= 1, got {self.max_components!r}")
        if not 0 < self.threshold_quantile <= 1:
            raise ValueError(f"threshold_quantile must be in (0, 1], got {self.threshold_quantile}")
        if self.threshold_scale <= 0:
            raise ValueError(f"threshold_scale must be > 0, got {self.threshold_scale}")
        if self.min_std < 0:
            raise ValueError(f"min_std must be >= 0, got {self.min_std}")
        if self.duration_weight < 0:
            raise ValueError(f"duration_weight must be >= 0, got {self.duration_weight}")
        if self.max_points < 10:
            raise ValueError(f"max_points must be >= 10, got {self.max_points}")

    def fit(self, X: Sequence[Trial] | Sequence[np.ndarray], y: Sequence[str] | None = None):
        """Fit one model per action from trials (or raw ``(n, 3)`` arrays with labels ``y``)."""
        self._validate()
        trials = _as_trials(X, y, self.preprocessor.rate_hz)
        by_action: dict[str, list[np.ndarray]] = {}
        for t in trials:
            by_action.setdefault(t.action, []).append(self.preprocessor.features(t.samples))
        self.models_ = {}
        for i, (name, feats) in enumerate(sorted(by_action.items())):
            self.models_[name] = self._fit_action(name, feats, seed=self.random_state + i)
        return self

    def _fit_action(self, name: str, feats: list[np.ndarray], seed: int) -> ActionModel:
        mixture = require("sklearn.mixture", "human action recognition")
        rng = np.random.default_rng(seed)
        length = int(np.median([len(f) for f in feats]))
        length = max(length, 8)
        normalised = np.stack([resample(f, length) for f in feats])  # (n, L, F)
        t = np.linspace(0.0, 1.0, length)
        means, covs, ks = [], [], []
        for g in self.groups:
            pts = np.concatenate(
                [np.column_stack([t, trial[:, list(g)]]) for trial in normalised], axis=0
            )
            if len(pts) > self.max_points:
                pts = pts[rng.choice(len(pts), self.max_points, replace=False)]
            best, best_bic = None, np.inf
            for k in range(1, max(1, min(self.max_components, len(pts) // 10)) + 1):
                gm = mixture.GaussianMixture(
                    k, covariance_type="full", reg_covar=1e-5, random_state=seed, n_init=1
                ).fit(pts)
                bic = gm.bic(pts)
                if bic < best_bic:
                    best, best_bic = gm, bic
            assert best is not None
            mu, cov = gmr(best.weights_, best.means_, best.covariances_, t)
            cov = cov + (self.min_std**2) * np.eye(len(g))[None]
            means.append(mu)
            covs.append(cov)
            ks.append(int(best.n_components))
        log_len = np.log([len(f) for f in feats])
        model = ActionModel(
            name,
            length,
            means,
            covs,
            ks,
            np.inf,
            tuple(self.groups),
            float(np.mean(log_len)),
            max(float(np.std(log_len)), 0.05),  # floor: a single trial gives std 0
            self.duration_weight,
        )
        dists = np.array([model.distance(f) for f in feats])
        model.threshold = float(np.quantile(dists, self.threshold_quantile) * self.threshold_scale)
        return model

    # ------------------------------------------------------------------------------- predict
    def _check_fitted(self) -> None:
        if not self.models_:
            raise FlexhrcError("the recogniser is not fitted: call fit() or load a model first")

    @property
    def classes_(self) -> list[str]:
        return sorted(self.models_)

    def features(self, samples: np.ndarray) -> np.ndarray:
        return self.preprocessor.features(samples)

    def distances(self, X: Sequence[Trial] | Sequence[np.ndarray]) -> np.ndarray:
        """Distance of every trial to every model, ``(n_trials, n_classes)`` (``classes_``)."""
        self._check_fitted()
        rows = []
        for x in X:
            samples = x.samples if isinstance(x, Trial) else np.asarray(x, dtype=float)
            rows.append(self.feature_distances(self.features(samples)))
        return np.asarray(rows)

    def feature_distances(self, features: np.ndarray) -> np.ndarray:
        """Distance of a pre-processed window to every model (order: ``classes_``)."""
        return np.array([self.models_[c].distance(features) for c in self.classes_])

    def thresholds(self) -> np.ndarray:
        """Recognition thresholds in ``classes_`` order."""
        return np.array([self.models_[c].threshold for c in self.classes_])

    def predict(self, X: Sequence[Trial] | Sequence[np.ndarray]) -> list[str]:
        """The best-matching action of each trial (lowest distance)."""
        d = self.distances(X)
        classes = self.classes_
        return [classes[i] for i in np.argmin(d, axis=1)]

    def model(self, name: str) -> ActionModel:
        self._check_fitted()
        try:
            return self.models_[name]
        except KeyError:
            raise UnknownNameError(
                f"unknown action {name!r} (the model knows: {', '.join(self.classes_)})"
            ) from None

    # ---------------------------------------------------------------------------- save/load
    def save(self, path: str | Path) -> Path:
        self._check_fitted()
        path = Path(path)
        meta = {
            "format": "flexhrc-hmp-gmr",
            "version": FORMAT_VERSION,
            "params": {
                **{k: getattr(self, k) for k in _saved_params()},
                "groups": [list(g) for g in self.groups],
                "preprocessor": asdict(self.preprocessor),
            },
            "models": [
                {k: getattr(self.models_[c], k) for k in _SAVED_MODEL} for c in self.classes_
            ],
        }
        arrays: dict[str, np.ndarray] = {"meta": np.array(json.dumps(meta))}
        for i, c in enumerate(self.classes_):
            for j, (mu, cov) in enumerate(
                zip(self.models_[c].means, self.models_[c].covariances, strict=True)
            ):
                arrays[f"m{i}_g{j}_mean"] = mu
                arrays[f"m{i}_g{j}_cov"] = cov
        with path.open("wb") as fh:
            np.savez_compressed(fh, **arrays)  # type: ignore[arg-type]
        return path

    @classmethod
    def load(cls, path: str | Path) -> GMMGMRRecognizer:
        import io
        import zipfile

        from flexhrc.files import read_bytes

        path = Path(path)
        if not path.exists():
            raise FlexhrcError(f"{path}: no such model file")
        raw = read_bytes(path)  # a folder, unreadable: one clear error
        if not raw:
            raise FormatError("not a flexhrc HAR model (empty file)", path)
        try:
            with np.load(io.BytesIO(raw), allow_pickle=False) as data:
                meta = json.loads(str(data["meta"]))
                arrays = {k: data[k] for k in data.files if k != "meta"}
        except (
            ValueError,
            KeyError,
            OSError,
            EOFError,
            zipfile.BadZipFile,
            json.JSONDecodeError,
            AttributeError,
        ) as exc:
            raise FormatError(f"not a flexhrc HAR model ({type(exc).__name__})", path) from None
        if not isinstance(meta, dict):
            raise FormatError("not a flexhrc HAR model (no metadata)", path)
        if meta.get("format") != "flexhrc-hmp-gmr" or meta.get("version") != FORMAT_VERSION:
            raise FormatError("not a flexhrc HAR model (format/version mismatch)", path)
        try:
            return cls._from_saved(meta, arrays)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise FormatError(
                f"damaged flexhrc HAR model ({type(exc).__name__}: {exc})", path
            ) from None

    @classmethod
    def _from_saved(cls, meta: dict, arrays: dict[str, np.ndarray]) -> GMMGMRRecognizer:
        p = meta["params"]
        groups = tuple(tuple(g) for g in p["groups"])
        rec = cls(
            **{k: p[k] for k in _saved_params()},
            preprocessor=Preprocessor(**p["preprocessor"]),
            groups=groups,
        )
        for i, m in enumerate(meta["models"]):
            rec.models_[m["name"]] = ActionModel(
                **{k: m[k] for k in _SAVED_MODEL},
                means=[arrays[f"m{i}_g{j}_mean"] for j in range(len(groups))],
                covariances=[arrays[f"m{i}_g{j}_cov"] for j in range(len(groups))],
                groups=groups,
                duration_weight=p["duration_weight"],
            )
        return rec


def _saved_params() -> list[str]:
    """The recogniser's plain parameters, in their order (groups and pre-processor apart)."""
    plain = (f.name for f in fields(GMMGMRRecognizer) if f.init)
    return [name for name in plain if name not in ("preprocessor", "groups")]


def _as_trials(X, y, rate_hz: float) -> list[Trial]:
    items = list(X)
    if not items:
        raise FlexhrcError("no training trials")
    if all(isinstance(x, Trial) for x in items):
        if y is not None:
            return [
                Trial(str(lab), x.samples, x.volunteer, x.rate_hz)
                for x, lab in zip(items, y, strict=True)
            ]
        return items
    if y is None:
        raise ValueError("labels y are required when X holds raw arrays")
    if len(y) != len(items):
        raise ValueError(f"X has {len(items)} trials but y has {len(y)} labels")
    return [
        Trial(str(lab), np.asarray(x), rate_hz=rate_hz) for x, lab in zip(items, y, strict=True)
    ]
