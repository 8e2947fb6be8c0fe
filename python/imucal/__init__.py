# SPDX-License-Identifier: MIT
"""imucal: accelerometer, gyroscope and magnetometer calibration from a hand-turned recording,
over numpy arrays: the library's streaming calibrator as the `imucal` command runs it, the same
options, the same results (docs/python.md).

    calibrate(acc, gyro, t=..., ...) -> Calibration    a recording's calibration
    field(acc, gyro, t=..., ...) -> Field              a recording through the field calibrator
    noise(acc, gyro, t=..., ...) -> Noise              a still recording's noise
    decode_record(record) -> Record                    a device record's contents
    Corrector(record).apply(acc, gyro, temp)           the firmware's correction
"""
from __future__ import annotations

import json as _json
import re as _re
from typing import Any, Dict, List, Literal, Optional, Tuple

from numpy.typing import ArrayLike

from . import _imucal
from ._results import (Calibration, Field, FieldBias, FloatArray, Magnetometer, Noise, NoiseTerm,
                       Parameters, Poses, Record, SensorNoise, TemperatureBias, TemperatureModel)

__version__: str = _imucal.__version__
ACCEL_PARAMETERS: Tuple[str, ...] = _imucal.ACCEL_PARAMETERS
"""The accelerometer's parameter names, in the model's order (the library's kAccelParamNames)."""
GYRO_PARAMETERS: Tuple[str, ...] = _imucal.GYRO_PARAMETERS
"""The gyroscope's parameter names, in the model's order (the library's kGyroParamNames)."""

__all__ = [
    "ACCEL_PARAMETERS", "GYRO_PARAMETERS", "Calibration", "Corrector", "Field", "FieldBias",
    "Magnetometer", "Noise", "NoiseTerm", "Parameters", "Poses", "Record", "SensorNoise",
    "TemperatureBias", "TemperatureModel", "calibrate", "decode_record", "field", "noise",
]

_FLAGS = ("poses", "refine_gyro_bias", "double")  # options that are flags of the command


def _command_args(options: Dict[str, Any]) -> List[str]:
    """The command's arguments for keyword options: accel_unit="counts" is --accel-unit counts,
    accel_range=(0, 65535) is --accel-range 0,65535, a flag is given when True, mag_align=False
    is --no-mag-align; None leaves an option out (the command's default)."""
    args: List[str] = []
    for name, value in options.items():
        if name == "mag_align":
            if not value:
                args.append("--no-mag-align")
            continue
        flag = "--" + name.replace("_", "-")
        if name in _FLAGS:
            if value:
                args.append(flag)
            continue
        if value is None:
            continue
        if isinstance(value, (tuple, list)):
            if len(value) != 2:
                raise ValueError(f"{name}: expected (low, high), found {value!r}")
            text = ",".join(_number_text(v) for v in value)
        else:
            text = _number_text(value)
        args += [flag, text]
    return args


def _number_text(value: Any) -> str:
    """A number as the command reads it back exactly (shortest round trip); other values as text."""
    if isinstance(value, float):
        return repr(float(value))
    return str(value)


def _in_python_terms(message: str) -> str:
    """The command's message with its options named as the keyword arguments: "--gravity: ..."
    is "gravity: ...", "--no-mag-align" is "mag_align=False"."""
    message = message.replace("--no-mag-align", "mag_align=False")
    return _re.sub(r"--([a-z][a-z-]*)", lambda m: m.group(1).replace("-", "_"), message)


def _needs_time(what: str, acc: Any, gyro: Any, t: Any, rate: Optional[float]) -> None:
    if (acc is not None or gyro is not None) and t is None and rate is None:
        raise ValueError(
            f"{what} needs the samples' times: give t= (seconds, shape (N,)) or rate= (Hz: "
            "sample i at i/rate s)" +
            ("; for one pose mean per row of acc, give poses=True" if what == "calibrate" else ""))


def calibrate(
    acc: Optional[ArrayLike] = None,
    gyro: Optional[ArrayLike] = None,
    *,
    t: Optional[ArrayLike] = None,
    rate: Optional[float] = None,
    mag: Optional[ArrayLike] = None,
    temp: Optional[ArrayLike] = None,
    poses: bool = False,
    time_unit: Literal["s", "ms", "us"] = "s",
    accel_unit: Literal["counts", "g", "mps2"] = "mps2",
    accel_lsb_per_g: Optional[float] = None,
    accel_zero: Optional[float] = None,
    accel_range: Optional[Tuple[float, float]] = None,
    gyro_unit: Literal["counts", "dps", "rads"] = "rads",
    gyro_lsb_per_dps: Optional[float] = None,
    gyro_range: Optional[Tuple[float, float]] = None,
    gravity: float = 9.80665,
    initial_rest: float = 2.0,
    min_rest: float = 0.6,
    refine_gyro_bias: bool = False,
    mag_unit: Literal["counts", "ut", "nt", "gauss"] = "ut",
    mag_lsb_per_ut: Optional[float] = None,
    mag_field_range: Tuple[float, float] = (20.0, 70.0),
    mag_min_coverage: float = 0.5,
    mag_align: bool = True,
    temp_order: Literal[1, 2] = 1,
    temp_min_span: float = 5.0,
    double: bool = False,
    memory: float = 256.0,
    device_id: int = 0,
    sensor_id: int = 0,
) -> Calibration:
    """Calibrates a hand-turned recording (still poses joined by turns) as `imucal calibrate`
    does: the same streaming calibrator, options and results (docs/commands.md).

    Readings (raw, in the units below; a row with a non-finite reading or a time out of order is
    skipped and listed in json["input"]["diagnostics"]):
      acc: accelerometer, shape (N, 3). gyro: gyroscope, (N, 3). mag: magnetometer, (N, 3); a
        row of NaN is a sample without a reading (a slower magnetometer). temp: deg C, (N,).
        Give acc (and gyro), or mag alone. The arrays are read where they are (any strides).
      t: each sample's time, (N,), in time_unit. rate: the configured sample rate, Hz: without
        t, sample i is at i/rate s; with t, intervals far from it are counted. acc or gyro
        without t or rate is refused (ValueError).
      poses: True: acc holds one pose mean per row (ax, ay, az), alone, without t or rate; the
        accelerometer is solved from the poses directly, with equal weights.
    Units and sensors:
      time_unit: the unit of t: "s", "ms" or "us".
      accel_unit: "counts", "g" or "mps2" (m/s^2). accel_lsb_per_g: nominal counts per g
        (counts; gives the "before" residual). accel_zero: nominal raw reading at 0 g
        (e.g. 32768; counts, default 0). accel_range: (low, high) full scale in raw units: a
        reading at or beyond it is saturated; in counts without it, int16 or uint16 is inferred.
      gyro_unit: "counts", "dps" or "rads" (rad/s). gyro_lsb_per_dps: nominal counts per deg/s
        (counts; else the scale is searched). gyro_range: as accel_range.
      gravity: local gravity, m/s^2 (9.7 .. 9.9).
    The calibration:
      initial_rest: s, the shortest still period that starts the run (its gyro bias and noise).
      min_rest: s, shorter still spells are not poses.
      refine_gyro_bias: estimate the gyro bias with the rest (12 parameters).
      double: run the double-precision reference instead of the device's float.
      memory: MB the samples are kept in between passes; beyond it the arrays are read again.
    Magnetometer (m_cal = S (m_raw + h)):
      mag_unit: "counts", "ut", "nt" or "gauss". mag_lsb_per_ut: nominal counts per uT
        (required with counts). mag_field_range: (low, high) accepted local field, uT.
      mag_min_coverage: fraction of the directions that must hold a sample (0 .. 1].
      mag_align: rotate S into the accelerometer's frame (from the poses, constant dip).
    Temperature (with temp; b(T) = b0 + b1 (T - T0) + b2 (T - T0)^2 replaces the bias):
      temp_order: 1 or 2. temp_min_span: deg C the poses' temperatures must span.
    The record:
      device_id, sensor_id: the record's ids (unsigned 32-bit).

    Returns a Calibration; a refused calibration is a result too (usable False, the reason in
    quality_reason, advice and summary). Raises ValueError with the reason for what the command
    refuses as bad usage: missing times, arrays of different lengths or shapes, an option out of
    its range, an ambiguous input.
    """
    if poses:
        extra = [name for name, value in (("gyro", gyro), ("mag", mag), ("temp", temp), ("t", t),
                                          ("rate", rate)) if value is not None]
        if acc is None or extra:
            raise ValueError("poses=True takes acc alone, one pose mean per row (ax, ay, az)" +
                             (": " + ", ".join(extra) + " not taken with it" if extra else ""))
    else:
        _needs_time("calibrate", acc, gyro, t, rate)
    args = _command_args(dict(
        poses=poses, time_unit=time_unit, accel_unit=accel_unit, accel_lsb_per_g=accel_lsb_per_g,
        accel_zero=accel_zero, accel_range=accel_range, gyro_unit=gyro_unit,
        gyro_lsb_per_dps=gyro_lsb_per_dps, gyro_range=gyro_range, gravity=gravity,
        initial_rest=initial_rest, min_rest=min_rest, refine_gyro_bias=refine_gyro_bias,
        rate=rate, mag_unit=mag_unit, mag_lsb_per_ut=mag_lsb_per_ut,
        mag_field_range=mag_field_range, mag_min_coverage=mag_min_coverage, mag_align=mag_align,
        temp_order=temp_order, temp_min_span=temp_min_span, double=double, memory=memory,
        device_id=device_id, sensor_id=sensor_id))
    try:
        text, summary, record, usable = _imucal.calibrate(acc, gyro, t, mag, temp, args)
    except ValueError as e:
        raise ValueError(_in_python_terms(str(e))) from None
    return Calibration._from_command(_json.loads(text), summary, record, usable)


def field(
    acc: Optional[ArrayLike] = None,
    gyro: Optional[ArrayLike] = None,
    *,
    t: Optional[ArrayLike] = None,
    rate: Optional[float] = None,
    mag: Optional[ArrayLike] = None,
    temp: Optional[ArrayLike] = None,
    prior: Optional[bytes] = None,
    time_unit: Literal["s", "ms", "us"] = "s",
    accel_unit: Literal["counts", "g", "mps2"] = "mps2",
    accel_lsb_per_g: Optional[float] = None,
    accel_zero: Optional[float] = None,
    accel_range: Optional[Tuple[float, float]] = None,
    gyro_unit: Literal["counts", "dps", "rads"] = "rads",
    gyro_lsb_per_dps: Optional[float] = None,
    gyro_zero: Optional[float] = None,
    gyro_range: Optional[Tuple[float, float]] = None,
    gravity: float = 9.80665,
    initial_rest: float = 2.0,
    gyro_noise: Optional[float] = None,
    accel_noise: Optional[float] = None,
    rest_piece: Optional[float] = None,
    mag_unit: Literal["counts", "ut", "nt", "gauss"] = "ut",
    mag_lsb_per_ut: Optional[float] = None,
    memory: float = 256.0,
) -> Field:
    """Replays a recording of any length through the field calibrator, one sample at a time as
    on the device, as `imucal field` does (docs/field.md, docs/commands.md): the gyro bias, the
    accelerometer's model and the magnetometer's hard iron it keeps, and every decision.

    Readings (raw, in the units below), as for calibrate():
      acc: accelerometer, shape (N, 3). gyro: gyroscope, (N, 3). mag: magnetometer, (N, 3); a
        row of NaN is a sample without a reading. temp: deg C, (N,).
      t: each sample's time, (N,), in time_unit; or rate: the sample rate, Hz (sample i at
        i/rate s). One of them is required.
      prior: a device record's bytes (Calibration.record, or what the firmware saved) to start
        from: its gyro bias and temperature model, its accelerometer part, its magnetometer's
        calibration. None: the library's nominal prior.
    Units and sensors:
      time_unit: the unit of t: "s", "ms" or "us".
      accel_unit: "counts", "g" or "mps2". accel_lsb_per_g: nominal counts per g (counts; the
        accelerometer's model needs it). accel_zero: nominal raw reading at 0 g (e.g. 32768).
        accel_range: (low, high) full scale in raw units.
      gyro_unit: "counts", "dps" or "rads". gyro_lsb_per_dps: nominal counts per deg/s (needed in
        counts without a prior). gyro_zero: nominal raw reading at zero rate (the prior's bias is
        -gyro_zero). gyro_range: as accel_range.
      gravity: local gravity, m/s^2 (9.7 .. 9.9).
      mag_unit: "counts", "ut", "nt" or "gauss". mag_lsb_per_ut: nominal counts per uT (counts:
        without it the magnetometer only verifies rests).
    The field calibrator:
      initial_rest: s, the still period the noise at rest is measured over (unless both noises
        are given).
      gyro_noise: rad/s, accel_noise: m/s^2: one sample's noise on one axis (default: measured).
      rest_piece: s, the longest piece a rest is judged in (default 5).
      memory: MB the samples before the noise is known may take.

    Returns a Field. Raises ValueError with the reason for what the command refuses (missing
    times, a prior that is no record, the gyro's scale unknown, no still period to measure the
    noise over).
    """
    _needs_time("field", acc, gyro, t, rate)
    args = _command_args(dict(
        rate=rate, time_unit=time_unit, accel_unit=accel_unit, accel_lsb_per_g=accel_lsb_per_g,
        accel_zero=accel_zero, accel_range=accel_range, gyro_unit=gyro_unit,
        gyro_lsb_per_dps=gyro_lsb_per_dps, gyro_zero=gyro_zero, gyro_range=gyro_range,
        gravity=gravity, initial_rest=initial_rest, gyro_noise=gyro_noise,
        accel_noise=accel_noise, rest_piece=rest_piece, mag_unit=mag_unit,
        mag_lsb_per_ut=mag_lsb_per_ut, memory=memory))
    try:
        text, summary, _ = _imucal.field(acc, gyro, t, mag, temp, prior, args)
    except ValueError as e:
        raise ValueError(_in_python_terms(str(e))) from None
    return Field._from_command(_json.loads(text), summary)


def noise(
    acc: Optional[ArrayLike] = None,
    gyro: Optional[ArrayLike] = None,
    *,
    t: Optional[ArrayLike] = None,
    rate: Optional[float] = None,
    time_unit: Literal["s", "ms", "us"] = "s",
    accel_unit: Literal["counts", "g", "mps2"] = "mps2",
    accel_lsb_per_g: Optional[float] = None,
    gyro_unit: Literal["counts", "dps", "rads"] = "rads",
    gyro_lsb_per_dps: Optional[float] = None,
) -> Noise:
    """The noise of a STILL recording (all of it), as `imucal noise` measures it (docs/noise.md):
    the Allan deviation per axis with its intervals, and the white noise N, random walk K, bias
    instability B and quantisation Q fitted to it.

      acc, gyro: raw readings, shape (N, 3); either or both.
      t: each sample's time, (N,), in time_unit; or rate: the sample rate, Hz (sample i at
        i/rate s). One of them is required.
      time_unit: the unit of t: "s", "ms" or "us".
      accel_unit: "counts", "g" or "mps2"; accel_lsb_per_g: counts per g. gyro_unit: "counts",
        "dps" or "rads"; gyro_lsb_per_dps: counts per deg/s. Counts without their scale are
        reported in counts (and kalibr is None).

    Returns a Noise. Raises ValueError with the reason for what the command refuses (no times,
    too few samples, a frozen axis, a reading too large for a variance).
    """
    if acc is None and gyro is None:
        raise ValueError("no readings: give acc, gyro or both")
    _needs_time("noise", acc, gyro, t, rate)
    args = _command_args(dict(
        rate=rate, time_unit=time_unit, accel_unit=accel_unit, accel_lsb_per_g=accel_lsb_per_g,
        gyro_unit=gyro_unit, gyro_lsb_per_dps=gyro_lsb_per_dps))
    try:
        text, summary, kalibr = _imucal.noise(acc, gyro, t, args)
    except ValueError as e:
        raise ValueError(_in_python_terms(str(e))) from None
    return Noise._from_command(_json.loads(text), summary, kalibr)


def decode_record(record: bytes) -> Record:
    """The contents of a device record (calibrate()'s Calibration.record, or a file the command
    or the firmware wrote; docs/record_format.md). Raises ValueError, saying why, if it is not
    a valid record."""
    return Record._from_dict(_imucal.decode_record(record), ACCEL_PARAMETERS, GYRO_PARAMETERS)


class Corrector:
    """The firmware's corrector (imucal::Corrector<float>), loaded from a device record: raw
    readings in, calibrated readings out, as on the device. Raises ValueError if the record is
    not valid or cannot be applied."""

    def __init__(self, record: bytes) -> None:
        """record: a device record's bytes (Calibration.record)."""
        self._corrector = _imucal.Corrector(record)

    def apply(self, acc: ArrayLike, gyro: ArrayLike,
              temp: Optional[ArrayLike] = None) -> Tuple[FloatArray, FloatArray]:
        """Raw acc and gyro, shape (N, 3), in; (acc in m/s^2, gyro in rad/s), each (N, 3), out.
        temp (N,), deg C, drives the record's temperature model as set_temperature() does on
        the device; without it the biases are those at the model's reference temperature."""
        return self._corrector.apply(acc, gyro, temp)
