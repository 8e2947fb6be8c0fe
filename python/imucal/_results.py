# SPDX-License-Identifier: MIT
"""The results of imucal's functions: small read-only classes, numbers as numpy arrays, made from
the JSON the command writes (which each result also keeps whole, as `json`)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
Json = Dict[str, Any]


def _array(values: Any, dtype: Any = np.float64) -> NDArray[Any]:
    """A read-only array; JSON's null (a NaN the command writes as null) is NaN."""
    if dtype is np.float64:
        values = _nan_for_none(values)
    a = np.array(values, dtype=dtype)
    a.flags.writeable = False
    return a


def _nan_for_none(values: Any) -> Any:
    if values is None:
        return math.nan
    if isinstance(values, (list, tuple)):
        return [_nan_for_none(v) for v in values]
    return values


def _value_sigma(entries: Mapping[str, Mapping[str, Any]], names: Sequence[str]
                 ) -> Tuple[FloatArray, FloatArray]:
    """The values and sigmas of {name: {"value", "sigma"}} in `names`' order."""
    return (_array([entries[n]["value"] for n in names]),
            _array([entries[n]["sigma"] for n in names]))


_AXES = ("x", "y", "z")


@dataclass(frozen=True, eq=False)
class Parameters:
    """A sensor model's parameters: `values` and their one-sigma uncertainties `sigma`, in the
    order of `names` (imucal.ACCEL_PARAMETERS or imucal.GYRO_PARAMETERS). Biases are in the
    sensor's raw unit and ADDED to the raw reading: a_cal = T K (a_raw + b)."""

    names: Tuple[str, ...]
    values: FloatArray
    sigma: FloatArray

    def __getitem__(self, name: str) -> float:
        """The value of the parameter `name` (e.g. "s_x"); KeyError for another name."""
        if name not in self.names:
            raise KeyError(f"{name!r}: not one of {', '.join(self.names)}")
        return float(self.values[self.names.index(name)])

    @classmethod
    def _from_json(cls, entries: Mapping[str, Mapping[str, Any]]) -> Parameters:
        names = tuple(entries)
        values, sigma = _value_sigma(entries, names)
        return cls(names, values, sigma)


@dataclass(frozen=True, eq=False)
class Magnetometer:
    """The magnetometer's calibration m_cal = S (m_raw + h), in uT: `soft_iron` S (3, 3), uT per
    raw unit; `hard_iron` h (3,), raw units, with its `hard_iron_sigma`; the local field
    strength `field_ut` and the fit's `quality` ("good", "fair", ...)."""

    soft_iron: FloatArray
    hard_iron: FloatArray
    hard_iron_sigma: FloatArray
    field_ut: float
    quality: str

    @classmethod
    def _from_json(cls, j: Json) -> Optional[Magnetometer]:
        if not j.get("usable"):
            return None
        h, h_sigma = _value_sigma(j["hard_iron"], _AXES)
        return cls(_array(j["soft_iron"]), h, h_sigma, float(j["field_ut"]), str(j["quality"]))


@dataclass(frozen=True, eq=False)
class TemperatureBias:
    """One sensor's bias against temperature, b(T) = b0 + b1 (T - T0) + b2 (T - T0)^2, in its
    raw unit: `coefficients` (order + 1, 3), rows b0, b1 (and b2), columns x, y, z, with their
    one-sigma uncertainties `sigma` of the same shape."""

    coefficients: FloatArray
    sigma: FloatArray

    @classmethod
    def _from_json(cls, j: Json, order: int) -> Optional[TemperatureBias]:
        if not j.get("usable"):
            return None
        rows = [_value_sigma(j["b%d" % k], _AXES) for k in range(order + 1)]
        return cls(_array([r[0] for r in rows]), _array([r[1] for r in rows]))


@dataclass(frozen=True, eq=False)
class TemperatureModel:
    """The biases' temperature model about `reference_c` (T0, deg C), of `order` 1 or 2, per
    sensor (None where that sensor's part did not fit)."""

    order: int
    reference_c: float
    accelerometer: Optional[TemperatureBias]
    gyroscope: Optional[TemperatureBias]

    @classmethod
    def _from_json(cls, j: Json) -> Optional[TemperatureModel]:
        if not j.get("present"):
            return None
        order = int(j["order"])
        accel = TemperatureBias._from_json(j["accelerometer"], order)
        gyro = TemperatureBias._from_json(j["gyroscope"], order)
        if accel is None and gyro is None:
            return None
        return cls(order, float(j["reference_c"]), accel, gyro)


@dataclass(frozen=True, eq=False, repr=False)
class Poses:
    """The rests found (or the pose means given), one row each: `t_begin_s`, `t_end_s` (K,);
    `samples` (K,); `mean` (K, 3), the raw accelerometer mean; `residual_after_mps2` (K,),
    |g| - |a_cal(mean)| (NaN where there is none)."""

    t_begin_s: FloatArray
    t_end_s: FloatArray
    samples: NDArray[np.int64]
    mean: FloatArray
    residual_after_mps2: FloatArray

    def __len__(self) -> int:
        return len(self.samples)

    def __repr__(self) -> str:
        return f"Poses({len(self)} poses)"

    @classmethod
    def _from_json(cls, poses: List[Json]) -> Poses:
        mean = _array([p["mean"] for p in poses]).reshape(len(poses), 3)
        return cls(_array([p["t_begin_s"] for p in poses]), _array([p["t_end_s"] for p in poses]),
                   _array([p["samples"] for p in poses], np.int64), mean,
                   _array([p["residual_after_mps2"] for p in poses]))


@dataclass(frozen=True, eq=False)
class Calibration:
    """What imucal.calibrate() found. A part is None where it was not calibrated (not in the
    input, or its fit failed: `summary` and `json[part]["status"]` say why)."""

    usable: bool
    """True when the calibration can be used (what the command's exit code 0 says)."""
    quality: str
    """One of "good", "fair", "poor", "none" (see `quality_reason`)."""
    quality_reason: str
    advice: Tuple[str, ...]
    """What to do next when the calibration is refused or weak."""
    accelerometer: Optional[Parameters]
    gyroscope: Optional[Parameters]
    magnetometer: Optional[Magnetometer]
    temperature: Optional[TemperatureModel]
    poses: Poses
    record: Optional[bytes] = field(repr=False)
    """The device record's bytes (imucal/store/record.hpp), None unless usable."""
    summary: str = field(repr=False)
    """The summary the command prints, its hints included."""
    json: Json = field(repr=False)
    """Everything, as `imucal calibrate --json` writes it."""

    @classmethod
    def _from_command(cls, json: Json, summary: str, record: Optional[bytes],
                      usable: bool) -> Calibration:
        accel, gyro = json["accelerometer"], json["gyroscope"]
        return cls(
            usable=usable,
            quality=str(json["quality"]),
            quality_reason=str(json["quality_reason"]),
            advice=tuple(json["advice"]),
            accelerometer=Parameters._from_json(accel["parameters"])
            if "parameters" in accel else None,
            gyroscope=Parameters._from_json(gyro["parameters"]) if "parameters" in gyro else None,
            magnetometer=Magnetometer._from_json(json["magnetometer"]),
            temperature=TemperatureModel._from_json(json["temperature"]),
            poses=Poses._from_json(json["poses"]),
            record=record,
            summary=summary,
            json=json,
        )


@dataclass(frozen=True, eq=False)
class NoiseTerm:
    """One term of the noise model per axis (x, y, z): `value`, `sigma` and whether it is
    `significant` (distinguishable from zero), each (3,)."""

    value: FloatArray
    sigma: FloatArray
    significant: NDArray[np.bool_]

    @classmethod
    def _from_json(cls, axes: List[Json], key: str) -> NoiseTerm:
        return cls(_array([a[key]["value"] for a in axes]), _array([a[key]["sigma"] for a in axes]),
                   _array([a[key]["significant"] for a in axes], np.bool_))


@dataclass(frozen=True, eq=False)
class SensorNoise:
    """One sensor's Allan deviation and fitted noise terms, in `unit` (SI when the units are
    known, else counts). AVAR(tau) = 3 Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3.
    `tau_s` (M,); `adev`, `adev_lo`, `adev_hi` (M, 3): the deviation per axis and its 68 %
    interval."""

    unit: str
    tau_s: FloatArray
    adev: FloatArray
    adev_lo: FloatArray
    adev_hi: FloatArray
    white_noise_N: NoiseTerm
    random_walk_K: NoiseTerm
    bias_instability_B: NoiseTerm
    quantisation_Q: NoiseTerm

    @classmethod
    def _from_json(cls, j: Json) -> SensorNoise:
        points, axes = j["allan_deviation"], j["axes"]

        def column(key: str) -> FloatArray:
            return _array([p[key] for p in points]).reshape(len(points), 3)

        return cls(str(j["unit"]), _array([p["tau"] for p in points]), column("adev"),
                   column("adev_lo"), column("adev_hi"),
                   *(NoiseTerm._from_json(axes, k) for k in
                     ("white_noise_N", "random_walk_K", "bias_instability_B", "quantisation_Q")))


@dataclass(frozen=True, eq=False)
class Noise:
    """What imucal.noise() measured on a still recording; a sensor not given is None."""

    samples: int
    duration_s: float
    rate_hz: float
    gyroscope: Optional[SensorNoise]
    accelerometer: Optional[SensorNoise]
    kalibr: Optional[str] = field(repr=False)
    """Kalibr's imu.yaml noise keys (None unless every sensor's unit is SI)."""
    summary: str = field(repr=False)
    """The summary `imucal noise` prints."""
    json: Json = field(repr=False)
    """Everything, as `imucal noise --json` writes it."""

    @classmethod
    def _from_command(cls, json: Json, summary: str, kalibr: Optional[str]) -> Noise:
        def sensor(key: str) -> Optional[SensorNoise]:
            return SensorNoise._from_json(json[key]) if key in json else None

        return cls(int(json["samples"]), float(json["duration_s"]), float(json["rate_hz"]),
                   sensor("gyroscope"), sensor("accelerometer"), kalibr, summary, json)


@dataclass(frozen=True, eq=False)
class FieldBias:
    """A sensor's bias as the field calibrator publishes it: raw units, ADDED to the raw reading,
    with its one-sigma per axis; `published` False: still the prior's."""

    published: bool
    value: FloatArray
    sigma: FloatArray
    unit: str

    @classmethod
    def _from_json(cls, j: Optional[Json]) -> Optional[FieldBias]:
        if j is None:
            return None
        sigma = j["sigma"]
        if not isinstance(sigma, list):
            sigma = [sigma] * 3
        return cls(bool(j["published"]), _array(j["value"]), _array(sigma), str(j["unit"]))


@dataclass(frozen=True, eq=False)
class Field:
    """What imucal.field() decided over a recording: the biases the device would apply at the end
    (the gyro's at the recording's last temperature; the accelerometer's and the magnetometer's
    hard iron when their models ran, else None), the gyro's misalignment and scale, the counts of
    rests and decisions, and every event in order."""

    gyro_bias: FieldBias
    accel_bias: Optional[FieldBias]
    mag_hard_iron: Optional[FieldBias]
    gyro_matrix: Parameters
    """The gyro's misalignment and scale the device would apply (imucal.GYRO_PARAMETERS' first
    nine): learned from the moves between rests when `gyro_matrix_published`, else the prior's."""
    gyro_matrix_published: bool
    counts: Dict[str, int]
    timeline: List[Json] = field(repr=False)
    """Each decision: time_s, sensor, kind, reason, temperature_c, chi2, the published bias after
    it (raw)."""
    summary: str = field(repr=False)
    """The summary `imucal field` prints."""
    json: Json = field(repr=False)
    """Everything, as `imucal field --json` writes it."""

    @classmethod
    def _from_command(cls, json: Json, summary: str) -> Field:
        gyro = FieldBias._from_json(json["gyro_bias"])
        assert gyro is not None
        matrix = json["gyro_matrix"]
        return cls(gyro, FieldBias._from_json(json.get("accel_bias")),
                   FieldBias._from_json(json.get("mag_hard_iron")),
                   Parameters._from_json(matrix["parameters"]), bool(matrix["published"]),
                   {k: int(v) for k, v in json["counts"].items()}, list(json["timeline"]),
                   summary, json)


@dataclass(frozen=True, eq=False)
class Record:
    """A device record, decoded: its format `version`, ids, `quality`, the sensors' parameters
    (None where the record has no such part), whether it holds a magnetometer calibration and a
    temperature model, and the temperature it was made at (None if unknown)."""

    version: int
    device_id: int
    sensor_id: int
    quality: str
    accelerometer: Optional[Parameters]
    gyroscope: Optional[Parameters]
    magnetometer: bool
    temperature_model: bool
    temperature_c: Optional[float]

    @classmethod
    def _from_dict(cls, d: Json, accel_names: Tuple[str, ...],
                   gyro_names: Tuple[str, ...]) -> Record:
        def part(key: str, names: Tuple[str, ...]) -> Optional[Parameters]:
            if key not in d:
                return None
            return Parameters(names, _array(d[key]["parameters"]), _array(d[key]["sigma"]))

        return cls(int(d["version"]), int(d["device_id"]), int(d["sensor_id"]), str(d["quality"]),
                   part("accelerometer", accel_names), part("gyroscope", gyro_names),
                   bool(d["magnetometer"]), bool(d["temperature_model"]),
                   None if d["temperature_c"] is None else float(d["temperature_c"]))
