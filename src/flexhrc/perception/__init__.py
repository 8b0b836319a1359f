"""Perception level of FlexHRC+ (paper 000, section III).

* :mod:`flexhrc.perception.human` — human action recognition from wrist inertial data with
  GMM/GMR templates (Bruno et al.), online recognition and a simulated wearable;
* :mod:`flexhrc.perception.scene` — objects from depth images / point clouds: support plane
  removal, Euclidean clustering, RANSAC primitives, PCA, rule-based types, tracking.

Importing this package is cheap: scikit-learn and SciPy (the ``perception`` extra) are imported
only by the functions that need them.
"""
