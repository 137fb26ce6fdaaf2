"""Identification of the motion model and the noises from the log itself: what omegahat's defaults run.

* :mod:`~omegahat.identification.likelihood` — the innovations' log-likelihood of a model (one EKF pass), with
  the measurement noise concentrated out;
* :mod:`~omegahat.identification.noise` — the attitude noise of the quietest part of the log (a bound the motion
  cannot inflate);
* :mod:`~omegahat.identification.identify` — the candidates fitted, the model chosen by its information
  criterion, the expected errors, the estimator to run;
* :mod:`~omegahat.identification.start` — the identified filter's ``fit`` start, over the longest window the
  motion allows;
* :mod:`~omegahat.identification.smoother` — the identified model's zero-lag estimate (``--smooth``);
* :mod:`~omegahat.identification.spectral` — the log's own Wiener smoother, where no model is chosen;
* :mod:`~omegahat.identification.fold` — the rate folded onto the band from beyond the Nyquist frequency (S6);
* :mod:`~omegahat.identification.causal` — the log's causal filter of the differences, where differencing runs.

``docs/theory/identification.md`` gives the equations and what was measured.
"""

from omegahat.identification.identify import MIN_SAMPLES, Candidate, Identification, identify
from omegahat.identification.likelihood import MODELS, Model

__all__ = ["MIN_SAMPLES", "MODELS", "Candidate", "Identification", "Model", "identify"]
