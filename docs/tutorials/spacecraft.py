"""Tutorial: a spacecraft's body rate from its star tracker and its known torques (run by tests/test_docs.py)."""

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.tuning import predicted_noise_std, sensor_gains

# --- 1. The spacecraft and what it measures -------------------------------------------------------------
J = np.diag([300.0, 250.0, 200.0])  # inertia, kg m^2 (body axes)
J_inv = np.linalg.inv(J)
rate_hz = 5.0  # star tracker: 5 attitude fixes per second
sigma = np.radians(10 / 3600)  # 10 arcsec of noise per axis, in rad


def torque(t):
    """Known control torque (N m, body axes) at time(s) t: a slew for 60 s, then quiet. Each command is held
    for one control period (1/rate_hz), as a flight computer does, and as the estimator assumes."""
    tk = np.floor(np.asarray(t) * rate_hz + 1e-9) / rate_hz  # the command's time
    on = np.where(tk < 60.0, 0.05, 0.0)
    return on[..., None] * np.stack([np.sin(0.1 * tk), np.cos(0.07 * tk), 0.5 + 0 * tk], axis=-1)


# --- 2. A stand-in for the flight log: the true motion (your telemetry replaces this block) ------------------
def derivative(x, tau):
    """Quaternion kinematics (scalar last: q̇ = ½ q ⊗ (ω, 0)) and Euler's equations, state x = (q, ω)."""
    (qx, qy, qz, qw), w = x[:4], x[4:]
    dq = 0.5 * np.array(
        [
            qw * w[0] + qy * w[2] - qz * w[1],
            qw * w[1] + qz * w[0] - qx * w[2],
            qw * w[2] + qx * w[1] - qy * w[0],
            -qx * w[0] - qy * w[1] - qz * w[2],
        ]
    )
    return np.concatenate([dq, J_inv @ (np.cross(J @ w, w) + tau)])


t = np.arange(0.0, 300.0, 1.0 / rate_hz)
tau = torque(t)  # the torque commanded at each fix and held until the next, (T, 3)
x = np.concatenate([Rotation.from_rotvec([0.1, -0.2, 0.3]).as_quat(), [0.01, -0.02, 0.015]])
truth = [x]
dt = 1.0 / rate_hz / 4  # classical Runge-Kutta, 4 steps per fix: far more accurate than the sensor
for k in range(t.size - 1):
    for _ in range(4):
        k1 = derivative(x, tau[k])
        k2 = derivative(x + dt / 2 * k1, tau[k])
        k3 = derivative(x + dt / 2 * k2, tau[k])
        k4 = derivative(x + dt * k3, tau[k])
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        x[:4] /= np.linalg.norm(x[:4])
    truth.append(x)
q_true, omega_true = np.array(truth)[:, :4], np.array(truth)[:, 4:]
rng = np.random.default_rng(1)
noise = Rotation.from_rotvec(rng.normal(0.0, sigma, (t.size, 3)))
q_meas = (Rotation.from_quat(q_true) * noise).as_quat()  # star tracker quaternions, x, y, z, w

# --- 3. Gains for this sensor, and the noise they will leave ----------------------------------------------
gains = sensor_gains(J, rate_hz=rate_hz, measurement_noise=sigma, bandwidth_hz=0.05)
predicted = predicted_noise_std(J, gains, rate_hz, sigma)
print("gains k =", np.round(gains.k, 1), " predicted noise per axis (rad/s):", predicted)

# --- 4. Estimate: the whole log at once (est.update(t, q, tau) does the same one fix at a time) ---------------
est = SarrasEstimator(J, gains=gains, warm_start=True)
omega_hat = est.run(t, q_meas, tau).omega  # NaN at the first fix: a warm start needs two

settled = t > 60.0  # after the warm start and the first bandwidth time constants
rms = np.sqrt(np.mean((omega_hat[settled] - omega_true[settled]) ** 2, axis=0))
print("rms error per axis after 60 s (rad/s):", rms)
print("plain differencing of the same fixes would give about", np.sqrt(2) * sigma * rate_hz, "rad/s per axis")
