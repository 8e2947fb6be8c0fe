// python/imucal_module.cpp: the `imucal` Python package (pybind11). numpy arrays in, the same
// calibration as `imucal calibrate` out (its JSON as a dict, its summary, its record), the
// record codec and the corrector the firmware runs. Host only.
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

// Keyword options as the command's flags: accel_unit="counts" is --accel-unit counts, a True
// flag (double=True) is --double; False and None are left out.
std::vector<std::string> flags(const py::kwargs& options) {
  std::vector<std::string> args;
  for (const auto& item : options) {
    std::string key = py::str(item.first);
    for (char& c : key)
      if (c == '_') c = '-';
    const py::handle v = item.second;
    if (v.is_none()) continue;
    if (py::isinstance<py::bool_>(v)) {
      if (v.cast<bool>()) args.push_back("--" + key);
      continue;
    }
    args.push_back("--" + key);
    args.push_back(py::str(v));
  }
  return args;
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

py::dict calibrate(const py::object& acc, const py::object& gyro, const py::object& t,
                   const py::object& mag, const py::object& temp, const py::kwargs& options) {
  const Arrays arrays = arrays_of(acc, gyro, t, mag, temp);
  const std::vector<std::string> args = flags(options);
  imucal::cli::MemoryRun run;
  int code = 0;
  {
    py::gil_scoped_release release;  // other Python threads run meanwhile
    code = imucal::cli::calibrate_memory(args, arrays.view, run);
  }
  if (code == 2) throw py::value_error(run.error);
  py::dict result = py::module_::import("json").attr("loads")(run.json);
  result["summary"] = run.summary;
  result["record"] = run.record.empty()
                         ? py::object(py::none())
                         : py::object(py::bytes(reinterpret_cast<const char*>(run.record.data()),
                                                run.record.size()));
  result["usable"] = code == 0;
  return result;
}

py::dict noise(const py::object& acc, const py::object& gyro, const py::object& t,
               const py::kwargs& options) {
  const Arrays arrays = arrays_of(acc, gyro, t, py::none(), py::none());
  const std::vector<std::string> args = flags(options);
  imucal::cli::NoiseRun run;
  int code = 0;
  {
    py::gil_scoped_release release;
    code = imucal::cli::noise_memory(args, arrays.view, run);
  }
  if (code != 0) throw py::value_error(run.error);
  py::dict result = py::module_::import("json").attr("loads")(run.json);
  result["summary"] = run.summary;
  result["kalibr"] = run.kalibr.empty() ? py::object(py::none()) : py::object(py::str(run.kalibr));
  return result;
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

PYBIND11_MODULE(imucal, m) {
  m.doc() =
      "imucal: accelerometer, gyroscope and magnetometer calibration from a hand-turned "
      "recording (the library's streaming calibrator, as the imucal command runs it).";
  // The parameters' names in the order of decode_record()'s lists: the keys of calibrate()'s
  // "parameters" dicts.
  py::list accel_names, gyro_names;
  for (const char* name : imucal::kAccelParamNames) accel_names.append(name);
  for (const char* name : imucal::kGyroParamNames) gyro_names.append(name);
  m.attr("ACCEL_PARAMETERS") = py::tuple(accel_names);
  m.attr("GYRO_PARAMETERS") = py::tuple(gyro_names);
  m.def("calibrate", &calibrate, py::arg("acc") = py::none(), py::arg("gyro") = py::none(),
        py::kw_only(), py::arg("t") = py::none(), py::arg("mag") = py::none(),
        py::arg("temp") = py::none(),
        "calibrate(acc, gyro=None, *, t=None, mag=None, temp=None, **options) -> dict\n\n"
        "acc, gyro, mag: (N, 3) raw readings; t: (N,) seconds (or rate=HZ); temp: (N,) deg C.\n"
        "options: the imucal calibrate options, dashes as underscores (accel_unit='counts',\n"
        "accel_lsb_per_g=4070, gravity=9.81744, rate=100, double=True, ...).\n"
        "Returns what `imucal calibrate --json` writes, as a dict, with 'summary' (the printed\n"
        "summary), 'record' (the device record's bytes, or None) and 'usable'. Raises\n"
        "ValueError where the command exits 2.");
  m.def("noise", &noise, py::arg("acc") = py::none(), py::arg("gyro") = py::none(), py::kw_only(),
        py::arg("t") = py::none(),
        "noise(acc=None, gyro=None, *, t=None, **options) -> dict\n\n"
        "The Allan deviation and fitted noise terms of a still recording, as `imucal noise\n"
        "--json` writes them, with 'summary' and 'kalibr' (Kalibr's imu.yaml text, or None\n"
        "unless the units are SI). Options as for calibrate (gyro_unit, rate, ...).");
  m.def("decode_record", &decode_record, py::arg("record"),
        "decode_record(record: bytes) -> dict: the parts and parameters of a device record.");
  py::class_<PyCorrector>(m, "Corrector",
                          "The firmware's corrector (float), loaded from a device record.")
      .def(py::init<const py::bytes&>(), py::arg("record"))
      .def("apply", &PyCorrector::apply, py::arg("acc"), py::arg("gyro"),
           py::arg("temp") = py::none(),
           "apply(acc, gyro, temp=None) -> (acc_cal, gyro_cal): raw (N, 3) readings in, m/s^2\n"
           "and rad/s out; temp (N,) deg C drives the record's temperature model.");
}
