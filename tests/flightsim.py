"""A simulated flight-controller log whose truth is known: a warm-up on the ground, handling tilts,
a flight with vibration and manoeuvres, a 2-s gap, a crash flip and the vehicle upside down to the
end — the messy log a user hands to ``twin calibrate`` and ``twin compare``.

Two IMUs (50 Hz unless asked otherwise) in the FRD body frame (a level board reads −1 g on z):

* IMU 0 warms 25 → 41 °C on the ground (enough span to calibrate on the static ground rows);
* IMU 1 sits on a cooler part of the board and warms only 30 → 36 °C (too little span: the
  calibration must refuse it with the numbers).

Truth per IMU: the accelerometer offset is the cubic :func:`logfixtures.cubic_offset_ms2` in its
temperature, the gyro bias a cubic in temperature (:data:`GYRO_CUBIC_RAD_S`), plus white noise.
Everything is drawn from one seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from logfixtures import G_MS2, T_REF_C, cubic_offset_ms2

RATE_HZ = 50.0
GROUND_S = 1800.0  # warm-up, static apart from two handling tilts
HANDLING_AT_S = (600.0, 1200.0)  # someone lifts and tilts the vehicle for ~5 s
HANDLING_S = 5.0
HANDLING_TILT_DEG = 20.0
FLIGHT_S = 180.0  # take-off at GROUND_S, crash at GROUND_S + FLIGHT_S
GAP_AT_S, GAP_S = 1900.0, 2.0  # a logging gap inside the flight
CRASH_S = 2.0  # the tumble: a 6 g spike, then upside down
TAIL_S = 1200.0  # upside down, still, to the end of the log
VIBRATION_G, VIBRATION_HZ = 0.5, 83.0  # motor vibration (aliased to 17 Hz by a 50 Hz log, 3 Hz by 10 Hz)
ACCEL_NOISE_MS2 = 0.02
GYRO_NOISE_RAD_S = 0.003
# gyro bias per axis [rad/s per °C, per °C², per °C³] about T_REF_C: ~0.01 °/s/°C class, as small MEMS gyros
GYRO_CUBIC_RAD_S = np.array([[2.0e-4, 3.0e-6, -4.0e-8],
                             [-1.5e-4, -2.0e-6, 5.0e-8],
                             [1.0e-4, 4.0e-6, 2.0e-8]])
# (start °C, rise °C, warm-up τ s) per IMU: IMU 0 spans ≈ 16 °C on the ground, IMU 1 ≈ 6 °C
WARMUP = ((25.0, 17.0, 600.0), (30.0, 6.5, 600.0))
DEVICE_IDS = (2428426, 3473674)
GYRO_DEVICE_IDS = (2428682, 3473930)


@dataclass(frozen=True)
class FlightTruth:
    """What the simulated log holds, and where: the rows a calibration may use and why the rest may not."""

    time_s: np.ndarray
    temperature_c: np.ndarray  # (n_imu, n)
    accel_ms2: np.ndarray  # (n_imu, n, 3)
    gyro_rad_s: np.ndarray  # (n_imu, n, 3)
    phase: np.ndarray  # per row: "ground", "handling", "flight", "crash", "inverted"
    device_ids: tuple[int, ...]
    gyro_device_ids: tuple[int, ...]

    def rows(self, phase: str) -> np.ndarray:
        return self.phase == phase


def gyro_bias_rad_s(temperature_c: np.ndarray) -> np.ndarray:
    """The known gyro bias, (n, 3) [rad/s]."""
    dt = np.asarray(temperature_c, float)[:, None] - T_REF_C
    c = GYRO_CUBIC_RAD_S
    return c[:, 0] * dt + c[:, 1] * dt**2 + c[:, 2] * dt**3


def _attitude(time_s: np.ndarray, phase: np.ndarray, rng) -> tuple[np.ndarray, np.ndarray]:
    """Roll and pitch [rad] along the log: level, handling tilts, flight manoeuvres, the flip."""
    roll, pitch = np.zeros(time_s.size), np.zeros(time_s.size)
    for t0 in HANDLING_AT_S:  # a smooth tilt up and back down (half-sine), about x
        k = (time_s >= t0) & (time_s < t0 + HANDLING_S)
        roll[k] = np.radians(HANDLING_TILT_DEG) * np.sin(np.pi * (time_s[k] - t0) / HANDLING_S)
    k = phase == "flight"
    tf = time_s[k] - GROUND_S
    roll[k] = np.radians(30.0) * np.sin(2 * np.pi * tf / 12.0) * np.sin(np.pi * tf / FLIGHT_S)
    pitch[k] = np.radians(20.0) * np.sin(2 * np.pi * tf / 17.0 + 1.0) * np.sin(np.pi * tf / FLIGHT_S)
    k = phase == "crash"
    roll[k] = np.pi * (time_s[k] - (GROUND_S + FLIGHT_S)) / CRASH_S
    roll[phase == "inverted"] = np.pi
    return roll, pitch


def simulate_flight(seed: int = 0, rate_hz: float = RATE_HZ) -> FlightTruth:
    """The whole log at ``rate_hz``, rows with the 2-s gap removed."""
    rng = np.random.default_rng(seed)
    end = GROUND_S + FLIGHT_S + CRASH_S + TAIL_S
    time_s = np.arange(0.0, end, 1.0 / rate_hz)
    time_s = time_s[(time_s < GAP_AT_S) | (time_s >= GAP_AT_S + GAP_S)]
    phase = np.full(time_s.size, "ground", dtype=object)
    for t0 in HANDLING_AT_S:
        phase[(time_s >= t0) & (time_s < t0 + HANDLING_S)] = "handling"
    phase[(time_s >= GROUND_S) & (time_s < GROUND_S + FLIGHT_S)] = "flight"
    phase[(time_s >= GROUND_S + FLIGHT_S) & (time_s < GROUND_S + FLIGHT_S + CRASH_S)] = "crash"
    phase[time_s >= GROUND_S + FLIGHT_S + CRASH_S] = "inverted"
    phase = phase.astype(str)
    roll, pitch = _attitude(time_s, phase, rng)
    # specific force in FRD at rest: −g·(−sinθ, sinφ cosθ, cosφ cosθ)
    gravity = -G_MS2 * np.column_stack([-np.sin(pitch), np.sin(roll) * np.cos(pitch), np.cos(roll) * np.cos(pitch)])
    rates = np.column_stack([np.gradient(roll, time_s), np.gradient(pitch, time_s), np.zeros(time_s.size)])
    flying = phase == "flight"
    motion = np.zeros((time_s.size, 3))
    motion[flying] = VIBRATION_G * G_MS2 * np.sin(2 * np.pi * VIBRATION_HZ * time_s[flying])[:, None] * [0.3, 0.3, 1.0]
    motion[flying, 2] += -0.3 * G_MS2 * np.sin(2 * np.pi * time_s[flying] / 9.0)  # climbs and descents
    crash = phase == "crash"
    motion[crash] += 6.0 * G_MS2 * np.exp(-((time_s[crash] - time_s[crash][0]) / 0.05) ** 2)[:, None] * [0.5, 0.2, -1.0]
    temps, accels, gyros = [], [], []
    for start_c, rise_c, tau_s in WARMUP:
        temp = start_c + rise_c * (1 - np.exp(-time_s / tau_s))
        cool = time_s >= GROUND_S  # airflow in flight cools the board, then it warms again at rest
        temp[cool] -= 3.0 * np.exp(-np.clip(time_s[cool] - GROUND_S - FLIGHT_S, 0, None) / 400.0) * \
            (1 - np.exp(-(time_s[cool] - GROUND_S) / 60.0))
        accel = gravity + motion + cubic_offset_ms2(temp) + rng.normal(0, ACCEL_NOISE_MS2, (time_s.size, 3))
        gyro = rates + gyro_bias_rad_s(temp) + rng.normal(0, GYRO_NOISE_RAD_S, (time_s.size, 3))
        gyro[flying] += rng.normal(0, 0.05, (int(flying.sum()), 3))  # vibration on the gyro
        temps.append(temp)
        accels.append(accel)
        gyros.append(gyro)
    return FlightTruth(time_s, np.array(temps), np.array(accels), np.array(gyros), phase, DEVICE_IDS,
                       GYRO_DEVICE_IDS)
