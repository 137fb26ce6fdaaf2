"""Tutorial: body rate from an accelerometer and a magnetometer, no attitude solution needed (run by
tests/test_docs.py)."""

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.tuning import sensor_gains

# --- 1. The two known directions, in the world frame (East-North-Up) ----------------------------------------
up = np.array([0.0, 0.0, 1.0])  # a resting accelerometer measures the reaction to gravity: "up", in the body
field = np.array([0.0, 0.48, -0.88])  # Earth's magnetic field direction where you are (inclination ~61°)
V = np.array([up, field / np.linalg.norm(field)])  # references, one row per sensor

# --- 2. A stand-in log: a slowly tumbling sensor box at 50 Hz (your sensor log replaces this block) --------------
rate = 50.0
t = np.arange(0.0, 30.0, 1.0 / rate)
w = np.array([0.3, -0.2, 0.4])  # constant body rate, rad/s (a free body with J = I keeps it)
attitude = Rotation.from_rotvec([0.2, 0.1, -0.4]) * Rotation.from_rotvec(np.outer(t, w))  # body -> world
rng = np.random.default_rng(5)
b = np.stack([attitude.inv().apply(v) for v in V], axis=1)  # b_i = Rᵀ v_i, shape (T, 2, 3)
b += rng.normal(0.0, 2e-3, b.shape)  # sensor noise after normalisation: about 2 mrad per axis
b[:, 0] *= 9.81  # units do not matter: each measured direction is normalised
b[:, 1] *= 48.0  # (m/s² and µT here)

# --- 3. Gains for two directions at 50 Hz with 2 mrad of noise: a 0.2 Hz bandwidth ------------------------------
J = np.eye(3)  # inertia unknown: the identity makes the model "rate locally constant"
gains = sensor_gains(J, rate_hz=rate, measurement_noise=2e-3, bandwidth_hz=0.2, references=V)

# --- 4. Estimate from the raw directions: references=V, one (2, 3) measurement per sample -------------------------
est = SarrasEstimator(J, gains=gains, references=V, warm_start=True)
omega_hat = est.run(t, b).omega  # rad/s, body axes (and .status: corrected, predicted, unavailable)
rms = np.sqrt(np.mean((omega_hat[t > 5.0] - w) ** 2))
print(f"rms error after 5 s: {rms:.4f} rad/s per axis (true rate {w} rad/s)")
print("the last estimate:", np.round(omega_hat[-1], 4))
