"""Identification of the motion model and the noises from the log itself: what omegahat's defaults run.

* :mod:`~omegahat.identification.likelihood` — the innovations' log-likelihood of a model (one EKF pass), with
  the measurement noise concentrated out;
* :mod:`~omegahat.identification.noise` — the attitude noise of the quietest part of the log (a bound the motion
  cannot inflate);
* :mod:`~omegahat.identification.identify` — the candidates fitted, the model chosen by its information
  criterion, the expected errors, the estimator to run.

``docs/theory/identification.md`` gives the equations and what was measured.
"""

from omegahat.identification.identify import Candidate, Identification, identify
from omegahat.identification.likelihood import MODELS, Model

__all__ = ["MODELS", "Candidate", "Identification", "Model", "identify"]
