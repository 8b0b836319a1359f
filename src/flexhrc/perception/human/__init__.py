"""Human action recognition from wrist inertial data (paper 000, section III).

Human motion primitives are modelled with Gaussian Mixture Models and Gaussian Mixture
Regression after Bruno, Mastrogiovanni, Sgorbissa et al. (CASE 2012, ICRA 2013):

* :mod:`.dataset` — HMP dataset reader and the CSV/NumPy user format (:class:`Trial`);
* :mod:`.preprocessing` — gravity/body split (:class:`Preprocessor`);
* :mod:`.models` — :class:`GMMGMRRecognizer` (fit/predict/save/load), :func:`gmr`;
* :mod:`.online` — :class:`OnlineRecognizer` over a stream, :class:`RecognisedAction`;
* :mod:`.wearable` — :class:`SimulatedWearable` synthesising streams from a model;
* :mod:`.mapping` — :class:`ActionMapping` to Task-Manager actions, :class:`HumanActionPublisher`;
* :mod:`.evaluation` — metrics, volunteer-wise cross-validation, the summary-feature baseline;
* :mod:`.synthetic` — toy trials and datasets for examples and tests without the HMP data.

Only numpy is imported here; SciPy and scikit-learn are imported when they are needed.
"""

from __future__ import annotations

from flexhrc.perception.human.dataset import HMP_SEVEN, Trial, load_dataset, read_trial_file
from flexhrc.perception.human.mapping import ActionMapping, HumanActionPublisher
from flexhrc.perception.human.models import ActionModel, GMMGMRRecognizer, gmr
from flexhrc.perception.human.online import OnlineRecognizer, RecognisedAction
from flexhrc.perception.human.preprocessing import Preprocessor
from flexhrc.perception.human.wearable import SimulatedWearable

__all__ = [
    "HMP_SEVEN",
    "ActionMapping",
    "ActionModel",
    "GMMGMRRecognizer",
    "HumanActionPublisher",
    "OnlineRecognizer",
    "Preprocessor",
    "RecognisedAction",
    "SimulatedWearable",
    "Trial",
    "gmr",
    "load_dataset",
    "read_trial_file",
]
