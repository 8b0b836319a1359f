"""Fixtures of the perception tests: a small toy HAR dataset and a model fitted on it."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
HMP = REPO.parent / "shared" / "datasets" / "hmp"


@pytest.fixture(scope="session")
def toy_trials():
    from flexhrc.perception.human.synthetic import toy_dataset

    return toy_dataset(seed=0, n_volunteers=3, trials_per_volunteer=2)


@pytest.fixture(scope="session")
def toy_model(toy_trials):
    from flexhrc.perception.human import GMMGMRRecognizer

    return GMMGMRRecognizer(max_components=3).fit(toy_trials)


@pytest.fixture(scope="session")
def toy_dir(tmp_path_factory):
    from flexhrc.perception.human.synthetic import write_toy_dataset

    return write_toy_dataset(
        tmp_path_factory.mktemp("toy") / "data", seed=1, n_volunteers=3, trials_per_volunteer=2
    )


@pytest.fixture(scope="session")
def hmp_dir(shared_dir):
    if not HMP.is_dir():
        pytest.skip("../shared/datasets/hmp is not present")
    return HMP
