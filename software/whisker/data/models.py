"""Classifiers beyond the paper's MLP: feature steps and models as scikit-learn estimators.

Every model is a scikit-learn `Pipeline` over the flat feature rows of `whisker.data.dataset`
(records x whiskers x (dx, dy) px, record-major), so it has fit / predict / predict_proba / score,
pickles into the model file of `whisker.data.classify.save_model`, and takes its parameters in the
constructors (`make_model(kind, seed, **params)` passes them through).

Feature steps: `whisker.data.features` (PolarFeatures, CyclicDFTFeatures). This module imports
scikit-learn only when a model is made, so the CLI can list `KINDS` cheaply.

Models (`KINDS`)
----------------
``mlp`` the paper's MLP (`make_classifier`, re-exported by whisker.data.classify); ``svc`` polar features, standard
scaling, RBF support-vector machine; ``trees`` polar features, extremely randomised trees;
``hgb`` polar features, histogram gradient boosting; ``dft-svc`` the cyclic-invariant features with
the same SVM. Defaults were chosen on 3 seeds of the trial and pose protocols
(docs/classification.md) and are reported on 10.
"""

from __future__ import annotations

import numpy as np

from whisker.data.dataset import PEER_SCALE

PAPER_PARAMS = dict(hidden=32, epochs=10, lr=0.01, batch_size=16, scale=PEER_SCALE)
"""The paper's MLP: 32 ReLU units, Adam lr 0.01, 10 epochs, batch 16 (notebook), inputs / 229."""


def _scale(X, scale=PEER_SCALE):
    """Input step of the pipeline: px -> px / scale (module-level so the model pickles)."""
    return np.asarray(X, dtype=float) / scale


def make_classifier(hidden: int = 32, epochs: int = 10, lr: float = 0.01, batch_size: int = 16,
                    scale: float = PEER_SCALE, seed: int | None = None):
    """The paper's MLP as a scikit-learn Pipeline (1/scale input step + `MLPClassifier`).

    ``epochs`` are full passes with Adam (``max_iter``; early stopping can not trigger before the
    last epoch). ConvergenceWarning after so few epochs is expected and silenced in `fit_quiet`.
    """
    from sklearn.neural_network import MLPClassifier
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import FunctionTransformer

    if hidden < 1 or epochs < 1 or lr <= 0 or batch_size < 1 or scale <= 0:
        raise ValueError(f"bad classifier parameters hidden={hidden} epochs={epochs} lr={lr} "
                         f"batch_size={batch_size} scale={scale}")
    mlp = MLPClassifier(hidden_layer_sizes=(int(hidden),), activation="relu", solver="adam",
                        learning_rate_init=lr, max_iter=int(epochs), batch_size=int(batch_size),
                        alpha=0.0, shuffle=True, n_iter_no_change=int(epochs) + 1, tol=0.0,
                        random_state=seed)
    return make_pipeline(FunctionTransformer(_scale, kw_args={"scale": float(scale)}), mlp)


KINDS = ("mlp", "svc", "trees", "hgb", "dft-svc")

DEFAULTS = {
    "svc": {"C": 10.0, "gamma": 0.001},
    "trees": {"n_estimators": 500},
    "hgb": {"max_iter": 100, "learning_rate": 0.1},
    "dft-svc": {"C": 10.0, "gamma": "scale"},
}
"""Estimator parameters per kind (the MLP's are whisker.data.classify.PAPER_PARAMS)."""


def make_model(kind: str = "mlp", seed: int | None = None, n_records: int = 8, n_whiskers: int = 8,
               **params):
    """A scikit-learn Pipeline of one of `KINDS`; ``params`` override `DEFAULTS` (or, for ``mlp``,
    `whisker.data.classify.make_classifier`'s arguments). Unknown kinds or parameters raise ValueError."""
    from sklearn.calibration import CalibratedClassifierCV
    from sklearn.ensemble import ExtraTreesClassifier, HistGradientBoostingClassifier
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler
    from sklearn.svm import SVC

    from whisker.data.features import CyclicDFTFeatures, PolarFeatures

    if kind not in KINDS:
        raise ValueError(f"unknown model {kind!r}; choose from {', '.join(KINDS)}")
    if kind == "mlp":
        return make_classifier(seed=seed, **{**PAPER_PARAMS, **params})
    p = {**DEFAULTS[kind], **params}
    shape = {"n_records": n_records, "n_whiskers": n_whiskers}
    try:
        if kind in ("svc", "dft-svc"):
            # class probabilities (the model file's checks and `predict` report them) by Platt scaling
            # on 5-fold out-of-fold decision values, then one SVM on all the training data
            # (ensemble=False: what SVC(probability=True), deprecated in scikit-learn 1.9, did)
            features = PolarFeatures(**shape) if kind == "svc" else CyclicDFTFeatures(**shape)
            svm = SVC(kernel="rbf", **p)
            return make_pipeline(features, StandardScaler(),
                                 CalibratedClassifierCV(svm, method="sigmoid", cv=5, ensemble=False))
        if kind == "trees":
            return make_pipeline(PolarFeatures(**shape), ExtraTreesClassifier(random_state=seed, n_jobs=1, **p))
        return make_pipeline(PolarFeatures(**shape), HistGradientBoostingClassifier(
            random_state=seed, early_stopping=False, **p))
    except TypeError as err:
        raise ValueError(f"bad parameter for model {kind!r}: {err}") from None
