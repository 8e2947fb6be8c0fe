// SPDX-License-Identifier: MIT
// python/imucal_module.cpp: `imucal._imucal`, the compiled part of the `imucal` Python package
// (pybind11; the typed API over it is python/imucal/__init__.py, its stub _imucal.pyi). numpy
// arrays and the command's options in, what `imucal calibrate`, `field` and `noise` print and write
// out (their JSON, summary, record); the record codec and the corrector the firmware runs. Host
// only.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <string>
#include <vector>

#include "cli.hpp"
#include "imucal/corrector.hpp"
#include "imucal/models/accel_model.hpp"
#include "imucal/models/gyro_model.hpp"
#include "imucal/store/record.hpp"
#include "imucal/version.hpp"

namespace py = pybind11;

namespace {

// Any strides: a view of a larger array is read where it is, not copied (an array of another
// type is converted to double once).
using Array = py::array_t<double, py::array::forcecast>;

// An (N, 3) array, or a length-N one for `columns` 1; none: None. Its rows (N) checked.
Array rows_of(const py::object& x, const char* name, py::ssize_t columns, py::ssize_t& n) {
  Array a = Array::ensure(x);
  if (!a) throw py::value_error(std::string(name) + ": not an array of numbers");
  const bool shape_ok = columns == 1 ? a.ndim() == 1 : a.ndim() == 2 && a.shape(1) == columns;
  if (!shape_ok)
    throw py::value_error(std::string(name) +
                          (columns == 1 ? ": expected shape (N,)" : ": expected shape (N, 3)"));
  if (n < 0) n = a.shape(0);
  if (a.shape(0) != n)
    throw py::value_error(std::string(name) + ": " + std::to_string(a.shape(0)) +
                          " rows, expected " + std::to_string(n) + " as the other arrays");
  return a;
}

// The arrays as the command's reader takes them: read where they are (kept alive by `keep`
// while the reader runs).
struct Arrays {
  imucal::cli::SampleArrays view;
  Array keep[5];
};

Arrays arrays_of(const py::object& acc, const py::object& gyro, const py::object& t,
                 const py::object& mag, const py::object& temp) {
  py::ssize_t n = -1;
  Arrays out;
  struct Part {
    const py::object& x;
    const char* name;
    py::ssize_t columns;
    imucal::cli::ArrayColumn& column;
  };
  imucal::cli::SampleArrays& v = out.view;
  const Part parts[5] = {{t, "t", 1, v.t},
                         {acc, "acc", 3, v.acc},
                         {gyro, "gyro", 3, v.gyro},
                         {mag, "mag", 3, v.mag},
                         {temp, "temp", 1, v.temp}};
  for (int k = 0; k < 5; ++k) {
    const Part& p = parts[k];
    if (p.x.is_none()) continue;
    Array& a = out.keep[k];
    a = rows_of(p.x, p.name, p.columns, n);
    p.column.data = reinterpret_cast<const char*>(a.data());
    p.column.row_bytes = a.strides(0);
    p.column.axis_bytes = p.columns == 3 ? a.strides(1) : 0;
  }
  if (n < 0) throw py::value_error("no readings: give acc (and gyro), or mag");
  v.rows = static_cast<std::size_t>(n);
  return out;
}

// `imucal calibrate` over the arrays with the command's options `args`: (its JSON, its summary,
// the record's bytes or None, whether usable). ValueError where the command exits 2.
py::tuple calibrate(const py::object& acc, const py::object& gyro, const py::object& t,
                    const py::object& mag, const py::object& temp,
                    const std::vector<std::string>& args) {
  const Arrays arrays = arrays_of(acc, gyro, t, mag, temp);
  imucal::cli::MemoryRun run;
  int code = 0;
  {
    py::gil_scoped_release release;  // other Python threads run meanwhile
    code = imucal::cli::calibrate_memory(args, arrays.view, run);
  }
  if (code == 2) throw py::value_error(run.error);
  const py::object record =
      run.record.empty() ? py::object(py::none())
                         : py::object(py::bytes(reinterpret_cast<const char*>(run.record.data()),
                                                run.record.size()));
  return py::make_tuple(run.json, run.summary, record, code == 0);
}

// `imucal field` over the arrays from the record `prior` (bytes, or None: the nominal prior):
// (its JSON, its summary, whether the gyro bias was published). ValueError where the command
// exits 2.
py::tuple field(const py::object& acc, const py::object& gyro, const py::object& t,
                const py::object& mag, const py::object& temp, const py::object& prior,
                const std::vector<std::string>& args) {
  const Arrays arrays = arrays_of(acc, gyro, t, mag, temp);
  std::vector<std::uint8_t> bytes;
  if (!prior.is_none()) {
    const std::string b = py::cast<py::bytes>(prior);
    bytes.assign(b.begin(), b.end());
  }
  imucal::cli::MemoryRun run;
  int code = 0;
  {
    py::gil_scoped_release release;
    code = imucal::cli::field_memory(args, arrays.view, prior.is_none() ? nullptr : &bytes, run);
  }
  if (code == 2) throw py::value_error(run.error);
  return py::make_tuple(run.json, run.summary, code == 0);
}

// `imucal noise` over the arrays: (its JSON, its summary, Kalibr's imu.yaml text or None).
py::tuple noise(const py::object& acc, const py::object& gyro, const py::object& t,
                const std::vector<std::string>& args) {
  const Arrays arrays = arrays_of(acc, gyro, t, py::none(), py::none());
  imucal::cli::NoiseRun run;
  int code = 0;
  {
    py::gil_scoped_release release;
    code = imucal::cli::noise_memory(args, arrays.view, run);
  }
  if (code != 0) throw py::value_error(run.error);
  const py::object kalibr =
      run.kalibr.empty() ? py::object(py::none()) : py::object(py::str(run.kalibr));
  return py::make_tuple(run.json, run.summary, kalibr);
}

imucal::CalibrationRecord decode(const py::bytes& data) {
  const std::string bytes = data;
  imucal::CalibrationRecord record;
  static const std::uint8_t kNothing = 0;
  const auto* p = bytes.empty() ? &kNothing : reinterpret_cast<const std::uint8_t*>(bytes.data());
  const imucal::Status st = imucal::decode_record(p, bytes.size(), record);
  if (st != imucal::Status::kOk)
    throw py::value_error(std::string("not a valid record: ") + imucal::to_string(st));
  return record;
}

template <typename V>
py::list as_list(const V& v) {
  py::list l;
  for (int k = 0; k < v.size(); ++k) l.append(static_cast<double>(v(k)));
  return l;
}

py::dict decode_record(const py::bytes& data) {
  const imucal::CalibrationRecord r = decode(data);
  py::dict d;
  d["version"] = r.version;
  d["device_id"] = r.device_id;
  d["sensor_id"] = r.sensor_id;
  d["quality"] = imucal::to_string(r.calibration.quality);
  if (r.parts & imucal::kRecordAccel)
    d["accelerometer"] = py::dict(py::arg("parameters") = as_list(r.calibration.accel.params),
                                  py::arg("sigma") = as_list(r.calibration.accel.sigma));
  if (r.parts & imucal::kRecordGyro)
    d["gyroscope"] = py::dict(py::arg("parameters") = as_list(r.calibration.gyro.params),
                              py::arg("sigma") = as_list(r.calibration.gyro.sigma));
  d["magnetometer"] = (r.parts & imucal::kRecordMag) != 0;
  d["temperature_model"] = (r.parts & imucal::kRecordTemperature) != 0;
  d["temperature_c"] =
      r.calibration.has_temperature
          ? py::object(py::float_(static_cast<double>(r.calibration.temperature_c)))
          : py::object(py::none());
  return d;
}

// The firmware's corrector (float), loaded from a record.
class PyCorrector {
 public:
  explicit PyCorrector(const py::bytes& record) {
    const imucal::Status st = c_.set(decode(record));
    if (st != imucal::Status::kOk)
      throw py::value_error(std::string("the record cannot be applied: ") + imucal::to_string(st));
  }
  // Raw (N, 3) readings in, calibrated (N, 3) out: m/s^2 and rad/s. With temp (N,), the
  // record's temperature model follows each sample's temperature (as set_temperature on the
  // device); without, the biases are those at the model's reference temperature.
  py::tuple apply(const py::object& acc, const py::object& gyro, const py::object& temp) {
    py::ssize_t n = -1;
    const Array a = rows_of(acc, "acc", 3, n), g = rows_of(gyro, "gyro", 3, n);
    const bool has_temp = !temp.is_none();
    Array te;
    if (has_temp) te = rows_of(temp, "temp", 1, n);
    Array out_a({n, py::ssize_t{3}}), out_g({n, py::ssize_t{3}});
    auto oa = out_a.mutable_unchecked<2>();
    auto og = out_g.mutable_unchecked<2>();
    for (py::ssize_t i = 0; i < n; ++i) {
      imucal::Vector3<float> ra, rg, ca, cg;
      for (py::ssize_t k = 0; k < 3; ++k) {
        ra(k) = static_cast<float>(a.at(i, k));
        rg(k) = static_cast<float>(g.at(i, k));
      }
      if (has_temp) {
        const imucal::Status st = c_.set_temperature(static_cast<float>(te.at(i)));
        if (st != imucal::Status::kOk && st != imucal::Status::kNotStarted)  // no model: none
          throw py::value_error("temp[" + std::to_string(i) + "]: " + imucal::to_string(st));
      }
      c_.apply(ra, rg, ca, cg);
      for (py::ssize_t k = 0; k < 3; ++k) {
        oa(i, k) = static_cast<double>(ca(k));
        og(i, k) = static_cast<double>(cg(k));
      }
    }
    return py::make_tuple(out_a, out_g);
  }

 private:
  imucal::Corrector<float> c_;
};

}  // namespace

PYBIND11_MODULE(_imucal, m) {
  m.doc() =
      "The compiled part of imucal: the command's calibration and noise runs over arrays, the "
      "record codec and the corrector. Use the typed API of the imucal package.";
  m.attr("__version__") = IMUCAL_VERSION_STRING;
  // The parameters' names in the order of decode_record()'s lists: the keys of the JSON's
  // "parameters" dicts.
  py::list accel_names, gyro_names;
  for (const char* name : imucal::kAccelParamNames) accel_names.append(name);
  for (const char* name : imucal::kGyroParamNames) gyro_names.append(name);
  m.attr("ACCEL_PARAMETERS") = py::tuple(accel_names);
  m.attr("GYRO_PARAMETERS") = py::tuple(gyro_names);
  m.def("calibrate", &calibrate, py::arg("acc"), py::arg("gyro"), py::arg("t"), py::arg("mag"),
        py::arg("temp"), py::arg("args"),
        "`imucal calibrate ARGS` over the arrays (each None or (N, 3), t and temp (N,)): "
        "(JSON text, summary, record bytes or None, usable). ValueError where the command exits "
        "2.");
  m.def("field", &field, py::arg("acc"), py::arg("gyro"), py::arg("t"), py::arg("mag"),
        py::arg("temp"), py::arg("prior"), py::arg("args"),
        "`imucal field ARGS` over the arrays from the record `prior` (bytes or None): (JSON "
        "text, summary, whether a gyro bias was published). ValueError where the command exits "
        "2.");
  m.def("noise", &noise, py::arg("acc"), py::arg("gyro"), py::arg("t"), py::arg("args"),
        "`imucal noise ARGS` over the arrays: (JSON text, summary, Kalibr's imu.yaml text or "
        "None). ValueError where the command exits 2.");
  m.def("decode_record", &decode_record, py::arg("record"),
        "The parts and parameters of a device record, as a dict (lists in the models' order). "
        "ValueError if it is not a valid record.");
  py::class_<PyCorrector>(m, "Corrector",
                          "The firmware's corrector (float), loaded from a device record.")
      .def(py::init<const py::bytes&>(), py::arg("record"))
      .def("apply", &PyCorrector::apply, py::arg("acc"), py::arg("gyro"),
           py::arg("temp") = py::none(),
           "Raw (N, 3) readings in, (acc m/s^2, gyro rad/s) out, each (N, 3); temp (N,) deg C "
           "drives the record's temperature model.");
}
