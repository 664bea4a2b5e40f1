"""A calibration document in words and a table: what a notebook shows of ``twin calibrate``
(``_repr_html_`` of :class:`~twin.calibration.result.CalibrationDocument`), written through
:mod:`twin.html` like the report's tables."""

from __future__ import annotations

from typing import TYPE_CHECKING

from twin.html import fragment, number, table_html

if TYPE_CHECKING:
    from twin.calibration.result import CalibrationDocument, ImuRecord

#: the firmware targets of a recommendation, as the report names them
TARGETS = (("px4", "PX4"), ("ardupilot", "ArduPilot"), ("c", "custom C and twin apply"))


def imu_sentences(imu: ImuRecord) -> list[str]:
    """One IMU's verdict in plain sentences: its data, what each firmware gets, and why.

    Parameters
    ----------
    imu : ImuRecord

    Returns
    -------
    list of str
    """
    device = "device id not logged" if imu.device_id is None else f"device id {imu.device_id}"
    best = imu.validation.best_overall
    out = [f"IMU {imu.instance} ({device}): {imu.samples} samples, {imu.temperature_span_c[0]:.1f} to "
           f"{imu.temperature_span_c[1]:.1f} °C, validated by {imu.protocol}.",
           "Recommended: " + "; ".join(f"{label}: {getattr(imu.recommended, k) or 'none (flagged or not fitted)'}"
                                       for k, label in TARGETS)
           + f". Best per axis: x {best.x}, y {best.y}, z {best.z}."]
    if imu.recommendation is not None:
        out.append(f"Why this default: {imu.recommendation.reason}.")
    return out


def heldout_rows(imu: ImuRecord) -> list[list[str]]:
    """Each method's held-out RMS per axis [mg], pooled over folds and tests, the noise floor last.

    Parameters
    ----------
    imu : ImuRecord

    Returns
    -------
    list of list of str
        Rows of IMU, method, x, y and z [mg].
    """
    v = imu.validation
    rows = [[f"IMU {imu.instance}", m, *(number(a, ".3f") for a in (r.x, r.y, r.z))]
            for m, r in (v.heldout_rms_mg or {}).items()]
    if v.noise_floor_mg is not None:
        f = v.noise_floor_mg
        rows.append([f"IMU {imu.instance}", "noise floor", *(number(a, ".3f") for a in (f.x, f.y, f.z))])
    return rows


def document_html(doc: CalibrationDocument) -> str:
    """The notebook display of a calibration: each IMU's verdict, then the held-out table.

    Parameters
    ----------
    doc : CalibrationDocument

    Returns
    -------
    str
        An HTML fragment.
    """
    sentences = [s for imu in doc.imus for s in imu_sentences(imu)]
    sentences += [f"IMU {s.instance} not calibrated: {s.reason}." for s in doc.skipped]
    return fragment(f"twin calibrate: {', '.join(f.path for f in doc.inputs)}", sentences,
                    table_html([row for imu in doc.imus for row in heldout_rows(imu)],
                          ["IMU", "method", "held-out x [mg]", "held-out y [mg]", "held-out z [mg]"],
                          caption="Held-out RMS, pooled over folds and tests", merge=1))
