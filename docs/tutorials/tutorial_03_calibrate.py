"""
Calibrate an IMU for PX4 and ArduPilot
======================================

A flight controller's accelerometer drifts with temperature; both PX4 and ArduPilot can remove
a polynomial of it, if someone fits the coefficients. ``twin calibrate`` fits them — the PX4
method exactly as ``process_sensor_caldata.py`` does, the ArduPilot method as ``tempcal_IMU.py``
does, a polynomial whose degree is chosen on held-out data and the lag-aware twin — and
*validates* each on branches of the log it was not fitted on. ``twin firmware`` then writes the
files the ground stations load.

Here we

1. simulate a thermal calibration of a level board with the twin, so the truth is known,
2. write it as a PX4 ULog (``sensor_accel`` messages, as the logger writes them),
3. run the calibration workflow on the ``.ulg`` file,
4. write the PX4 ``.params`` and the ArduPilot ``.parm`` files and read their lines,
5. look at the held-out validation and the residual before and after.
"""

# %%
# A thermal calibration, simulated
# --------------------------------
# A three-axis IIS328DQ on a level board (FRD axes: z points down, so it reads −1 g) in a chamber:
# two cycles of −10 → 60 → −10 °C at 1.5 °C/min with 15-min dwells, logged at 1 Hz. The IMU's
# temperature sensor sits on the board side of the package and the MEMS die follows it with a
# 90-s time constant, so on the ramps the logged temperature runs ahead of the one that sets the
# drift. Each axis has its own zero-g offset and a cubic bias tempco; z also has a scale-factor
# tempco (it carries the 1 g).

import tempfile
from pathlib import Path

import numpy as np

from twin.model.axes import imu_log_fields
from twin.model.scenario import parse_scenario
from twin.model.simulate import simulate

SCENARIO = """
name: px4_thermal_cal
description: level three-axis IMU, two chamber cycles -10..60 °C, die 90 s behind the IMU thermometer
seed: 4242
program:
  start_c: -10.0
  cycles: 2
  steps:
    - {type: hold, dwell_s: 900}
    - {type: ramp, target_c: 60.0, ramp_c_per_h: 90}
    - {type: hold, dwell_s: 900}
    - {type: ramp, target_c: -10.0, ramp_c_per_h: 90}
chamber:
  lumped: {board_tau_s: 300.0, die_tau_s: 90.0}
  thermometer: {attached_to: board, tau_s: 0.0, noise_c: 0.01, resolution_c: 0.01, sample_rate_hz: 1.0}
device:
  sensor: {part: IIS328DQ, full_scale_g: 2, odr_hz: 50}
  axes:
    x:
      zero_g_offset_mg: 15.0
      effects:
        static_bias_tc: {tc1_mg_per_c: 0.20, tc2_mg_per_c2: 0.004, tc3_mg_per_c3: -0.00015}
    y:
      zero_g_offset_mg: -10.0
      effects:
        static_bias_tc: {tc1_mg_per_c: -0.10, tc2_mg_per_c2: -0.003, tc3_mg_per_c3: 0.0001}
    z:
      zero_g_offset_mg: 25.0
      effects:
        static_bias_tc: {tc1_mg_per_c: 0.30, tc2_mg_per_c2: 0.002, tc3_mg_per_c3: 0.00012}
        scale_factor_tc: {tc1_ppm_per_c: 150.0}
test_plan:
  logger_rate_hz: 1.0
  orientations:
    - {at_s: 0, gravity_g: [0, 0, -1]}
"""

loaded = parse_scenario(SCENARIO, "px4_thermal_cal.yaml")
ds = simulate(loaded)
fields = imu_log_fields(ds)  # the logged columns of a three-axis dataset: time, temperature, accel (n, 3) [g]
print(f"{len(ds)} samples over {ds['time_s'][-1] / 3600:.1f} h; logged temperature "
      f"{fields['temperature_c'].min():.1f}…{fields['temperature_c'].max():.1f} °C")

# %%
# Write it as a PX4 ULog
# ----------------------
# The ULog format (https://docs.px4.io/main/en/dev_log/ulog_file_format.html) is a header and a
# stream of messages ``uint16 size, uint8 type, payload``: flag bits (``B``), message formats
# (``F``), a subscription (``A``) binding a message id to a topic instance, then data (``D``).
# ``sensor_accel`` carries the driver's ``device_id`` — PX4 applies ``TC_A0_*`` only to the
# sensor whose id matches ``TC_A0_ID`` — the acceleration in m/s² and the temperature.
# (The project reads ULogs through pyulog but has no ULog writer; these few lines are one.)

import struct

G0 = 9.80665  # m/s² per g
DEVICE_ID = 2490378  # the driver's id, as PX4 logs it (an ICM-20602-style id on SPI bus 1)
SENSOR_ACCEL = ("sensor_accel:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;float x;float y;"
                "float z;float temperature;uint32_t error_count;uint8_t[3] clip_counter;uint8_t samples;")
ROW = struct.Struct("<QQIffffI3BB")


def message(kind: str, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def write_ulog(path: Path, time_s, temperature_c, accel_g, device_id: int) -> Path:
    """One ``sensor_accel`` instance (multi_id 0) as a ULog file."""
    out = [b"ULog\x01\x12\x35", bytes([1]), struct.pack("<Q", 0)]
    out.append(message("B", bytes(16) + struct.pack("<3Q", 0, 0, 0)))  # no compat/incompat flags, no appended data
    out.append(message("F", SENSOR_ACCEL.encode()))
    out.append(message("I", bytes([len(b"char[3] sys_name")]) + b"char[3] sys_name" + b"PX4"))
    out.append(message("A", struct.pack("<BH", 0, 0) + b"sensor_accel"))
    t_us = (1_000_000 + np.round(np.asarray(time_s) * 1e6)).astype(np.uint64)  # time since boot [µs]
    ms2 = (np.asarray(accel_g) * G0).astype(np.float32)
    for t, temp, (x, y, z) in zip(t_us, np.asarray(temperature_c, np.float32), ms2):
        out.append(message("D", struct.pack("<H", 0) + ROW.pack(int(t), int(t), device_id, x, y, z, temp, 0, 0, 0, 0, 1)))
    path.write_bytes(b"".join(out))
    return path


work_dir = tempfile.TemporaryDirectory(prefix="twin_calibrate_")  # removed at the end, or at exit
work = Path(work_dir.name)
log = write_ulog(work / "thermal_cal.ulg", fields["time_s"], fields["temperature_c"], fields["accel_g"], DEVICE_ID)
print(f"wrote {log.name}: {log.stat().st_size / 1e6:.1f} MB")

from twin.measurement import read_imu_logs

[imu] = read_imu_logs(log)
print(f"read back: instance {imu.instance}, device_id {imu.device_id}, {len(imu)} rows, "
      f"median |a| {np.median(np.linalg.norm(imu.accel_g, axis=1)):.4f} g")

# %%
# Calibrate
# ---------
# :func:`~twin.workflows.calibrate.run_calibrate` is ``twin calibrate`` as a function. It reads
# the log, keeps its still rows (the log-quality stage), cuts it into heating and cooling
# branches, fits every method on all of them and validates each by leaving branches out.

from twin.workflows.calibrate import CalibrateOptions, run_calibrate

run = run_calibrate(CalibrateOptions(logs=[log]))
[cal] = run.calibrations
print(f"IMU {cal.instance} (device id {cal.device_id}): {cal.samples} rows, "
      f"{cal.temperature_span_c[0]:.1f}…{cal.temperature_span_c[1]:.1f} °C, validated by {cal.protocol}")
print("recommended:", cal.recommended())
if cal.recommendation is not None:
    print("why:", cal.recommendation.reason)

# %%
# The validation table: held-out RMS [mg] per axis, for each fold (which branches were left out)
# and each method, pooled over the fold's held-out branches. The noise floor is what a perfect
# compensation would leave. ``…_as_applied`` rows are the written file applied the way the
# vehicle applies it (float32; PX4 updates its offset only after the temperature moved 1 °C).
# ``cal.validation.table(reference="px4")`` prints the same per held-out branch as well.

v = cal.validation
for fold in dict.fromkeys(sc.fold for sc in v.scores):
    print(f"{fold}")
    px4_rms = v.rms_mg("px4", "overall", fold)
    for method in v.methods:
        rms = v.rms_mg(method, "overall", fold)
        gain = " / ".join(f"{100 * (1 - a / b):+3.0f} %" for a, b in zip(rms, px4_rms))
        print(f"    {method:22s} " + " / ".join(f"{x:5.2f}" for x in rms) + f"    ({gain} vs px4)")
print("noise floor [mg]:", " / ".join(f"{x:.2f}" for x in v.noise_floor_mg))
print("best per axis:", ", ".join(f"{a}: {m}" for a, m in zip("xyz", v.best_method)))

# %%
# The fitted equations, PX4's and the lag-aware twin's:

for name in ("px4", "twin"):
    print(f"--- {name}\n{cal.fitted[name].equation()}")

# %%
# Write the firmware files
# ------------------------
# The calibration document (``run.document``, what ``twin calibrate -o cal.json`` writes) keeps
# every method. :func:`~twin.calibration.deploy.export_calibration` is ``twin firmware``: it
# checks every value as the firmware holds it (float32, TMIN < TMAX, the device id), writes the
# file, and reads it back as the ground station would before renaming it into place.

from twin.calibration.deploy import export_calibration

doc = run.document.to_json()
px4 = export_calibration(doc, "px4", work / "thermal_cal.params")
ardupilot = export_calibration(doc, "ardupilot", work / "thermal_cal.parm")
for export in (px4, ardupilot):
    print(f"=== {export.path.name} ({export.lines} lines) — {'; '.join(export.notes)}")
    print(export.path.read_text())

# %%
# Residual before and after
# -------------------------
# What each method leaves on the rows it was fitted on, against temperature, as 1-min means
# (a single sample is dominated by the noise and the 1-mg digit of the ±2 g range); heating dots,
# cooling crosses. Before, the drift spans several mg. After, a static polynomial (PX4 shown;
# ArduPilot's cubic lands on it) leaves the two ramp directions apart, because the die lags the
# logged temperature; the lag-aware twin brings them together.
# (:class:`~twin.reporting.study_plots.ResidualByMethodDisplay` is the plot of the calibration
# report.)

import matplotlib.pyplot as plt

from twin.calibration import make_X
from twin.reporting.study_plots import ResidualByMethodDisplay

X = make_X(imu.time_s, imu.temperature_c)
level = np.median(imu.accel_g, axis=0)
residual = {"raw − median": (imu.accel_g - level) * 1e3}
residual |= {m: (imu.accel_g - cal.fitted[m].predict(X)) * 1e3 for m in ("px4", "ardupilot", "twin")}

block = 60  # samples per mean: 1 min at 1 Hz
n = len(imu) // block * block


def means(a):
    return np.asarray(a)[:n].reshape(n // block, block, *np.shape(a)[1:]).mean(axis=1)


temp_min = means(imu.temperature_c)
heating_min = np.gradient(temp_min) > 0
floor_min = np.asarray(v.noise_floor_mg) / np.sqrt(block)

fig, axes = plt.subplots(2, 3, figsize=(13, 7), sharex=True)
for i, axis in enumerate("xyz"):
    ResidualByMethodDisplay(axis, temp_min, {"raw − median": means(residual["raw − median"][:, i])},
                            heating_min, floor_min[i]).plot(ax=axes[0, i])
    axes[0, i].set_title(f"axis {axis}: before", fontsize=10)
    ResidualByMethodDisplay(axis, temp_min, {m: means(residual[m][:, i]) for m in ("px4", "twin")},
                            heating_min, floor_min[i]).plot(ax=axes[1, i])
    axes[1, i].set_title(f"axis {axis}: after each method", fontsize=10)
fig.tight_layout()

for m, r in residual.items():
    print(f"{m:13s} RMS x / y / z: " + " / ".join(f"{x:.3f}" for x in np.sqrt(np.mean(r**2, axis=0))) + " mg  "
          "(1-min means: " + " / ".join(f"{x:.3f}" for x in np.sqrt(np.mean(means(r) ** 2, axis=0))) + " mg)")

# %%
# Since the log is simulated we can check against the truth: the drift the device really had
# (relative to its value at the median temperature), and what the PX4 cubic recovered.

truth = np.column_stack([ds[f"truth/{a}/drift_g"] for a in "xyz"]) * 1e3
error_px4 = (cal.fitted["px4"].predict(X) * 1e3 - truth)
error_twin = (cal.fitted["twin"].predict(X) * 1e3 - truth)
for name, e in (("px4", error_px4), ("twin", error_twin)):
    e = e - e.mean(axis=0)  # the constant is the vehicle's level calibration, not the tempco
    print(f"{name:5s} recovered drift − true drift, RMS x / y / z: "
          + " / ".join(f"{v:.3f}" for v in np.sqrt(np.mean(e**2, axis=0))) + " mg")

# %%
# On the vehicle
# --------------
# * PX4: QGroundControl ▸ Parameters ▸ Tools ▸ Load from file, reboot, then redo the ordinary
#   accelerometer calibration (``TC_A0_X0`` holds the offset at TREF).
# * ArduPilot: ``param load thermal_cal.parm`` in MAVProxy (or Mission Planner), reboot.
# * ``twin apply cal.json new.ulg -o compensated.csv`` compensates a new log with the default.

work_dir.cleanup()
