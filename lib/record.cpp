// The calibration record's encoder and validating decoder (format:
// include/imucal/store/record.hpp).
#include "imucal/store/record.hpp"

#include <Eigen/LU>  // determinant()
#include <cmath>
#include <cstring>

#include "little_endian.hpp"

namespace imucal {
namespace {

constexpr std::uint8_t kMagic[4] = {0x49, 0x4D, 0x43, 0x52};  // "IMCR"
constexpr std::size_t kCrcBytes = 4;
constexpr std::size_t kSectionHeaderBytes = 4;

enum Tag : std::uint8_t {
  kTagInfo = 1,
  kTagAccel = 2,
  kTagGyro = 3,
  kTagMag = 4,
  kTagTemperature = 5,
  kLastKnownTag = kTagTemperature,
};
constexpr std::uint16_t kInfoBytes = 12;
constexpr std::uint16_t kAccelBytes = 4 + 4 * (2 * kAccelParams + 1);
constexpr std::uint16_t kGyroBytes = 4 + 4 * (2 * kGyroParams + 1);
constexpr std::uint16_t kMagBytes = 4 + 4 * (9 + 3 + 3 + kMagSymEntries + 5);
constexpr std::uint16_t kTemperatureHeadBytes = 16;
constexpr std::uint16_t temperature_bytes(int order) {
  // Two sensors, each (order + 1) coefficient vectors and as many sigma vectors of 3 floats.
  return static_cast<std::uint16_t>(kTemperatureHeadBytes + 2 * 2 * (order + 1) * 3 * 4);
}
constexpr std::uint16_t kKnownParts = kRecordAccel | kRecordGyro | kRecordMag | kRecordTemperature;
static_assert(kRecordHeaderBytes + 4 + kInfoBytes + 4 + kAccelBytes + 4 + kGyroBytes + 4 +
                      kMagBytes + 4 + temperature_bytes(2) + 4 <=
                  kRecordMaxBytes,
              "every part fits the largest record");

// Plausible bounds: an IMU's operating temperatures, any sample rate a MEMS part offers.
constexpr float kMinTemperature = -100.0f, kMaxTemperature = 200.0f;
constexpr float kMaxSampleRate = 1.0e6f;

// ---- Bytes ---------------------------------------------------------------------------------

class Writer {
 public:
  Writer(std::uint8_t* out, std::size_t capacity) : out_(out), capacity_(capacity) {}
  void u8(std::uint8_t v) {
    if (pos_ < capacity_) out_[pos_] = v;
    ++pos_;
  }
  void u16(std::uint16_t v) {
    u8(static_cast<std::uint8_t>(v & 0xFFu));
    u8(static_cast<std::uint8_t>(v >> 8));
  }
  void u32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i) u8(static_cast<std::uint8_t>((v >> (8 * i)) & 0xFFu));
  }
  void f32(float v) {
    std::uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    u32(bits);
  }
  void put_u16_at(std::size_t at, std::uint16_t v) {
    if (at + 1 < capacity_) {
      out_[at] = static_cast<std::uint8_t>(v & 0xFFu);
      out_[at + 1] = static_cast<std::uint8_t>(v >> 8);
    }
  }
  std::size_t pos() const { return pos_; }
  bool fits() const { return pos_ <= capacity_; }

 private:
  std::uint8_t* out_;
  std::size_t capacity_;
  std::size_t pos_ = 0;
};

using detail::load_u16;
using detail::load_u32;

float load_f32(const std::uint8_t* p) {
  const std::uint32_t bits = load_u32(p);
  float v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

// Reads a section's payload field by field; the first out-of-range field sets `bad` (its
// offset in the record). Reads past the payload never happen: the callers check its length.
class Reader {
 public:
  Reader(const std::uint8_t* record, std::size_t at) : rec_(record), pos_(at) {}
  std::uint8_t u8() { return rec_[pos_++]; }
  std::uint16_t u16() {
    const std::uint16_t v = load_u16(rec_ + pos_);
    pos_ += 2;
    return v;
  }
  float f32() {
    const float v = load_f32(rec_ + pos_);
    pos_ += 4;
    return v;
  }
  // Checks that the field just read is acceptable; remembers the first one that is not.
  void expect(bool ok, std::size_t size) {
    if (!ok && !failed()) bad_ = pos_ - size;
  }
  void zero_u8() { expect(u8() == 0, 1); }
  void zero_u16() { expect(u16() == 0, 2); }
  float finite_f32() {
    const float v = f32();
    expect(std::isfinite(v), 4);
    return v;
  }
  float non_negative_f32() {
    const float v = f32();
    expect(std::isfinite(v) && v >= 0.0f, 4);
    return v;
  }
  bool failed() const { return bad_ != kNone; }
  std::size_t bad() const { return bad_; }

 private:
  static constexpr std::size_t kNone = ~std::size_t(0);
  const std::uint8_t* rec_;
  std::size_t pos_;
  std::size_t bad_ = kNone;
};

// ---- Validity of a record's values (shared by encode and decode) -----------------------------

bool temperature_ok(bool known, float t) {
  return known ? (std::isfinite(t) && t >= kMinTemperature && t <= kMaxTemperature) : t == 0.0f;
}
bool sample_rate_ok(float r) { return std::isfinite(r) && r >= 0.0f && r <= kMaxSampleRate; }
bool accel_scale_ok(float s) { return std::isfinite(s) && s > 0.0f; }
bool gyro_scale_ok(float s) { return std::isfinite(s) && s != 0.0f; }
bool sigma_ok(float s) { return std::isfinite(s) && s >= 0.0f; }

template <class V>
bool all_of_finite(const V& v) {
  for (int i = 0; i < v.size(); ++i)
    if (!std::isfinite(v(i))) return false;
  return true;
}
template <class V>
bool all_sigmas_ok(const V& v) {
  for (int i = 0; i < v.size(); ++i)
    if (!sigma_ok(v(i))) return false;
  return true;
}

bool accel_ok(const AccelCalibration<float>& a) {
  return a.poses >= kAccelMinPoses && a.poses <= 0xFFFF && all_of_finite(a.params) &&
         accel_scale_ok(a.params(kScaleX)) && accel_scale_ok(a.params(kScaleY)) &&
         accel_scale_ok(a.params(kScaleZ)) && all_sigmas_ok(a.sigma) && sigma_ok(a.residual_rms);
}
bool gyro_ok(const GyroCalibration<float>& g) {
  return g.moves >= 1 && g.moves <= 0xFFFF && all_of_finite(g.params) &&
         gyro_scale_ok(g.params(kGyroScaleX)) && gyro_scale_ok(g.params(kGyroScaleY)) &&
         gyro_scale_ok(g.params(kGyroScaleZ)) && all_sigmas_ok(g.sigma) && sigma_ok(g.residual_rms);
}
bool coverage_ok(float c) { return std::isfinite(c) && c >= 0.0f && c <= 1.0f; }
bool dip_ok(float d) { return std::isfinite(d) && d >= -90.0f && d <= 90.0f; }
bool field_ok(float f) { return std::isfinite(f) && f > 0.0f; }
// A soft iron that mirrors space (or collapses it) is not a calibration.
bool soft_iron_ok(const Matrix3<float>& m) { return m.determinant() > 0.0f; }
bool mag_ok(const MagCalibration<float>& m) {
  return m.samples >= 1 && m.samples <= 0xFFFF && m.quality <= Quality::kGood &&
         all_of_finite(m.soft_iron.reshaped()) && soft_iron_ok(m.soft_iron) &&
         all_of_finite(m.hard_iron) && all_sigmas_ok(m.hard_iron_sigma) &&
         all_sigmas_ok(m.soft_iron_sigma) && field_ok(m.field_ut) && sigma_ok(m.fit_error_pct) &&
         coverage_ok(m.coverage) && dip_ok(m.dip_deg) && sigma_ok(m.dip_sigma_deg);
}
bool temperature_bias_ok(const TemperatureBias<float>& b, int order) {
  return all_of_finite(b.b0) && all_of_finite(b.b1) && all_of_finite(b.b2) &&
         all_sigmas_ok(b.b0_sigma) && all_sigmas_ok(b.b1_sigma) && all_sigmas_ok(b.b2_sigma) &&
         (order == 2 || (b.b2.isZero(0.0f) && b.b2_sigma.isZero(0.0f)));
}
bool temperature_range_ok(float t) { return temperature_ok(true, t); }
// A sensor's coefficients only with the sensor: bounded through its matrix, applied to it alone.
bool temperature_model_ok(const TemperatureModel<float>& t, std::uint16_t parts) {
  const bool a = succeeded(t.accel.status), g = succeeded(t.gyro.status);
  return (t.order == 1 || t.order == 2) && (a || g) && (!a || (parts & kRecordAccel)) &&
         (!g || (parts & kRecordGyro)) && t.rests >= 1 && t.rests <= 0xFFFF &&
         std::isfinite(t.reference_c) && std::isfinite(t.min_c) && std::isfinite(t.max_c) &&
         (!a || temperature_bias_ok(t.accel, t.order)) &&
         (!g || temperature_bias_ok(t.gyro, t.order));
}
bool record_ok(const CalibrationRecord& r) {
  const Calibration<float>& c = r.calibration;
  return (r.parts & ~kKnownParts) == 0 && r.parts != 0 && c.quality <= Quality::kGood &&
         temperature_ok(c.has_temperature, c.temperature_c) && sample_rate_ok(c.sample_rate_hz) &&
         (!(r.parts & kRecordAccel) || accel_ok(c.accel)) &&
         (!(r.parts & kRecordGyro) || gyro_ok(c.gyro)) &&
         (!(r.parts & kRecordMag) || mag_ok(r.mag)) &&
         (!(r.parts & kRecordTemperature) || temperature_model_ok(r.temperature, r.parts));
}

// The section a bound's value lives in.
Tag bound_tag(Bound b, bool from_temperature_model) {
  if (from_temperature_model) return kTagTemperature;
  switch (b) {
    case Bound::kAccelScale:
    case Bound::kAccelMisalignment:
    case Bound::kAccelOffset:
      return kTagAccel;
    case Bound::kGyroScale:
    case Bound::kGyroMisalignment:
    case Bound::kGyroOffset:
      return kTagGyro;
    case Bound::kMagSoftIron:
    case Bound::kMagOffset:
    case Bound::kMagField:
      return kTagMag;
    default:
      return kTagInfo;
  }
}

// A temperature model's bound, through the matrices of the sensors in the record r.
Bound temperature_bound(const CalibrationRecord& r, const TemperatureModel<float>& t) {
  const Matrix3<float> ma = accel_matrix(r.calibration.accel.params);
  const Matrix3<float> mg = gyro_matrix<float>(r.calibration.gyro.params);
  return temperature_model_bound(t, (r.parts & kRecordAccel) ? &ma : nullptr,
                                 (r.parts & kRecordGyro) ? &mg : nullptr);
}

Bound record_bound_in(const CalibrationRecord& r, bool* in_temperature_model) {
  *in_temperature_model = false;
  const Calibration<float>& c = r.calibration;
  const bool accel = (r.parts & kRecordAccel) != 0, gyro = (r.parts & kRecordGyro) != 0;
  if (c.has_temperature && !temperature_plausible(c.temperature_c)) return Bound::kTemperature;
  if (!sample_rate_ok(c.sample_rate_hz)) return Bound::kSampleRate;
  Bound b = Bound::kNone;
  if (accel && (b = accel_bound(c.accel.params)) != Bound::kNone) return b;
  if (gyro && (b = gyro_bound(c.gyro.params)) != Bound::kNone) return b;
  if ((r.parts & kRecordMag) &&
      (b = mag_bound(r.mag.soft_iron, r.mag.hard_iron, r.mag.field_ut)) != Bound::kNone)
    return b;
  if (r.parts & kRecordTemperature) {
    b = temperature_bound(r, r.temperature);
    *in_temperature_model = b != Bound::kNone;
  }
  return b;
}

// ---- Sections --------------------------------------------------------------------------------

void read_info(Reader& in, Calibration<float>& c) {
  const std::uint8_t quality = in.u8();
  in.expect(quality <= static_cast<std::uint8_t>(Quality::kGood), 1);
  c.quality = static_cast<Quality>(quality);
  const std::uint8_t flags = in.u8();
  in.expect((flags & ~1u) == 0, 1);
  c.has_temperature = (flags & 1u) != 0;
  in.zero_u16();
  c.temperature_c = in.f32();
  in.expect(temperature_ok(c.has_temperature, c.temperature_c), 4);
  c.sample_rate_hz = in.f32();
  in.expect(sample_rate_ok(c.sample_rate_hz), 4);
}

// A sensor's parameters (the three from first_scale on checked as scales), sigmas, residual.
template <class V>
void read_block(Reader& in, V& params, V& sigma, float& rms, int first_scale,
                bool (*scale_ok)(float)) {
  for (int i = 0; i < params.size(); ++i) {
    params(i) = in.finite_f32();
    if (i >= first_scale && i < first_scale + 3) in.expect(scale_ok(params(i)), 4);
  }
  for (int i = 0; i < sigma.size(); ++i) sigma(i) = in.non_negative_f32();
  rms = in.non_negative_f32();
}
template <class V>
void write_block(Writer& w, const V& params, const V& sigma, float rms) {
  for (int i = 0; i < params.size(); ++i) w.f32(params(i));
  for (int i = 0; i < sigma.size(); ++i) w.f32(sigma(i));
  w.f32(rms);
}

void read_accel(Reader& in, AccelCalibration<float>& a) {
  a.poses = in.u16();
  in.expect(a.poses >= kAccelMinPoses, 2);
  in.zero_u16();
  read_block(in, a.params, a.sigma, a.residual_rms, kScaleX, accel_scale_ok);
  a.status = Status::kOk;
}

void read_gyro(Reader& in, GyroCalibration<float>& g) {
  g.moves = in.u16();
  in.expect(g.moves >= 1, 2);
  const std::uint8_t flags = in.u8();
  in.expect((flags & ~1u) == 0, 1);
  g.bias_refined = (flags & 1u) != 0;
  in.zero_u8();
  read_block(in, g.params, g.sigma, g.residual_rms, kGyroScaleX, gyro_scale_ok);
  g.status = Status::kOk;
}

void read_vector(Reader& in, Vector3<float>& v) {
  for (int i = 0; i < 3; ++i) v(i) = in.finite_f32();
}
void read_sigmas(Reader& in, Vector3<float>& v) {
  for (int i = 0; i < 3; ++i) v(i) = in.non_negative_f32();
}
void write_vector(Writer& w, const Vector3<float>& v) {
  for (int i = 0; i < 3; ++i) w.f32(v(i));
}

void read_mag(Reader& in, MagCalibration<float>& m) {
  m.samples = in.u16();
  in.expect(m.samples >= 1, 2);
  const std::uint8_t quality = in.u8();
  in.expect(quality <= static_cast<std::uint8_t>(Quality::kGood), 1);
  m.quality = static_cast<Quality>(quality);
  const std::uint8_t flags = in.u8();
  in.expect((flags & ~1u) == 0, 1);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.soft_iron(r, c) = in.finite_f32();
  in.expect(soft_iron_ok(m.soft_iron), 36);
  read_vector(in, m.hard_iron);
  read_sigmas(in, m.hard_iron_sigma);
  for (int i = 0; i < kMagSymEntries; ++i) m.soft_iron_sigma(i) = in.non_negative_f32();
  m.field_ut = in.f32();
  in.expect(field_ok(m.field_ut), 4);
  m.fit_error_pct = in.non_negative_f32();
  m.coverage = in.f32();
  in.expect(coverage_ok(m.coverage), 4);
  m.dip_deg = in.f32();
  in.expect(dip_ok(m.dip_deg), 4);
  m.dip_sigma_deg = in.non_negative_f32();
  m.status = Status::kOk;
  m.alignment_status = (flags & 1u) ? Status::kOk : Status::kNotStarted;
}
void write_mag(Writer& w, const MagCalibration<float>& m) {
  w.u8(kTagMag);
  w.u8(0);
  w.u16(kMagBytes);
  w.u16(static_cast<std::uint16_t>(m.samples));
  w.u8(static_cast<std::uint8_t>(m.quality));
  w.u8(succeeded(m.alignment_status) ? 1 : 0);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) w.f32(m.soft_iron(r, c));
  write_vector(w, m.hard_iron);
  write_vector(w, m.hard_iron_sigma);
  for (int i = 0; i < kMagSymEntries; ++i) w.f32(m.soft_iron_sigma(i));
  w.f32(m.field_ut);
  w.f32(m.fit_error_pct);
  w.f32(m.coverage);
  w.f32(m.dip_deg);
  w.f32(m.dip_sigma_deg);
}

// A sensor's temperature coefficients; all are read (an unusable sensor's are zeros).
void read_temperature_bias(Reader& in, TemperatureBias<float>& b, int order, bool usable) {
  read_vector(in, b.b0);
  read_vector(in, b.b1);
  if (order == 2) read_vector(in, b.b2);
  read_sigmas(in, b.b0_sigma);
  read_sigmas(in, b.b1_sigma);
  if (order == 2) read_sigmas(in, b.b2_sigma);
  b.status = usable ? Status::kOk : Status::kNotStarted;
  if (!usable) b = TemperatureBias<float>{};
}
void write_temperature_bias(Writer& w, const TemperatureBias<float>& b, int order) {
  const bool usable = succeeded(b.status);
  const TemperatureBias<float> zero{};
  const TemperatureBias<float>& v = usable ? b : zero;
  write_vector(w, v.b0);
  write_vector(w, v.b1);
  if (order == 2) write_vector(w, v.b2);
  write_vector(w, v.b0_sigma);
  write_vector(w, v.b1_sigma);
  if (order == 2) write_vector(w, v.b2_sigma);
}

// The order comes first: it sets the payload's length (checked by the caller through `length`).
// The flags' bits 0 and 1 are the parts bits of the accelerometer and the gyro: the coefficients
// of a sensor the record does not hold are read and left out, a model of none of its sensors is
// refused.
static_assert(kRecordAccel == 1u && kRecordGyro == 2u, "the temperature flags' bits");
bool read_temperature(Reader& in, std::size_t length, std::uint16_t parts,
                      TemperatureModel<float>& t) {
  t.order = in.u8();
  in.expect(t.order == 1 || t.order == 2, 1);
  if (in.failed()) return true;
  if (length < temperature_bytes(t.order)) return false;
  const unsigned flags = in.u8();
  in.expect((flags & ~3u) == 0 && (flags & parts) != 0, 1);
  t.rests = in.u16();
  in.expect(t.rests >= 1, 2);
  t.reference_c = in.f32();
  in.expect(temperature_range_ok(t.reference_c), 4);
  t.min_c = in.f32();
  in.expect(temperature_range_ok(t.min_c), 4);
  t.max_c = in.f32();
  in.expect(temperature_range_ok(t.max_c) && t.min_c <= t.max_c, 4);
  read_temperature_bias(in, t.accel, t.order, (flags & parts & kRecordAccel) != 0);
  read_temperature_bias(in, t.gyro, t.order, (flags & parts & kRecordGyro) != 0);
  return true;
}
void write_temperature(Writer& w, const TemperatureModel<float>& t) {
  w.u8(kTagTemperature);
  w.u8(0);
  w.u16(temperature_bytes(t.order));
  w.u8(static_cast<std::uint8_t>(t.order));
  w.u8(static_cast<std::uint8_t>((succeeded(t.accel.status) ? 1u : 0u) |
                                 (succeeded(t.gyro.status) ? 2u : 0u)));
  w.u16(static_cast<std::uint16_t>(t.rests));
  w.f32(t.reference_c);
  w.f32(t.min_c);
  w.f32(t.max_c);
  write_temperature_bias(w, t.accel, t.order);
  write_temperature_bias(w, t.gyro, t.order);
}

template <typename Scalar, class V>
bool to_float(const V& in, Eigen::Matrix<float, V::RowsAtCompileTime, 1>& out) {
  for (int i = 0; i < in.size(); ++i) {
    out(i) = static_cast<float>(in(i));
    if (!std::isfinite(out(i))) return false;
  }
  return true;
}

template <typename Scalar>
MagCalibration<float> mag_to_float(const MagCalibration<Scalar>& m) {
  MagCalibration<float> f;
  f.status = m.status;
  f.soft_iron = m.soft_iron.template cast<float>();
  f.hard_iron = m.hard_iron.template cast<float>();
  f.hard_iron_sigma = m.hard_iron_sigma.template cast<float>();
  f.soft_iron_sigma = m.soft_iron_sigma.template cast<float>();
  f.field_ut = static_cast<float>(m.field_ut);
  f.fit_error_pct = static_cast<float>(m.fit_error_pct);
  f.coverage = static_cast<float>(m.coverage);
  f.samples = m.samples;
  f.iterations = m.iterations;
  f.quality = m.quality;
  f.alignment_status = m.alignment_status;
  const bool aligned = succeeded(m.alignment_status);
  f.dip_deg = aligned ? static_cast<float>(m.dip_deg) : 0.0f;
  f.dip_sigma_deg = aligned ? static_cast<float>(m.dip_sigma_deg) : 0.0f;
  f.alignment_rotation = m.alignment_rotation.template cast<float>();
  f.alignment_sigma = m.alignment_sigma.template cast<float>();
  f.alignment_rests = m.alignment_rests;
  return f;
}

template <typename Scalar>
TemperatureBias<float> bias_to_float(const TemperatureBias<Scalar>& b, int order, bool keep) {
  TemperatureBias<float> f;
  if (!keep || !succeeded(b.status)) return f;
  f.status = Status::kOk;
  f.b0 = b.b0.template cast<float>();
  f.b1 = b.b1.template cast<float>();
  f.b0_sigma = b.b0_sigma.template cast<float>();
  f.b1_sigma = b.b1_sigma.template cast<float>();
  if (order == 2) {
    f.b2 = b.b2.template cast<float>();
    f.b2_sigma = b.b2_sigma.template cast<float>();
  }
  return f;
}

// The coefficients of the sensors in `parts` only; the rests counted up to the format's 65535.
template <typename Scalar>
TemperatureModel<float> temperature_to_float(const TemperatureModel<Scalar>& t,
                                             std::uint16_t parts) {
  TemperatureModel<float> f;
  f.order = t.order;
  f.reference_c = static_cast<float>(t.reference_c);
  f.min_c = static_cast<float>(t.min_c);
  f.max_c = static_cast<float>(t.max_c);
  f.rests = t.rests < 0xFFFF ? t.rests : 0xFFFF;
  f.accel = bias_to_float(t.accel, t.order, (parts & kRecordAccel) != 0);
  f.gyro = bias_to_float(t.gyro, t.order, (parts & kRecordGyro) != 0);
  return f;
}

// Adds the temperature model m to a record that is right without it, if the two are right
// together; otherwise the record stays as it was and *bound names the bound m broke (kNone: a
// value that does not fit the format). A model without coefficients for the record's sensors
// is not a part: left out.
void add_temperature(CalibrationRecord& r, const TemperatureModel<float>& m, Bound* bound) {
  if (!succeeded(m.accel.status) && !succeeded(m.gyro.status)) return;
  const Bound b = temperature_bound(r, m);
  if (b == Bound::kNone && temperature_model_ok(m, r.parts)) {
    r.temperature = m;
    r.parts = static_cast<std::uint16_t>(r.parts | kRecordTemperature);
  } else if (bound != nullptr) {
    *bound = b;
  }
}

Status fail(Status s, std::size_t offset, std::size_t* error_offset) {
  if (error_offset != nullptr) *error_offset = offset;
  return s;
}

}  // namespace

CalibrationRecord::CalibrationRecord() = default;
CalibrationRecord::CalibrationRecord(const CalibrationRecord& other) = default;
CalibrationRecord& CalibrationRecord::operator=(const CalibrationRecord& other) = default;

std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc) {
  // CRC of each nibble value, reflected polynomial 0xEDB88320.
  static constexpr std::uint32_t kNibble[16] = {0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu,
                                                0x76DC4190u, 0x6B6B51F4u, 0x4DB26158u, 0x5005713Cu,
                                                0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
                                                0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    crc = (crc >> 4) ^ kNibble[crc & 0xFu];
    crc = (crc >> 4) ^ kNibble[crc & 0xFu];
  }
  return ~crc;
}

Bound record_bound(const CalibrationRecord& r) {
  bool in_model = false;
  return record_bound_in(r, &in_model);
}

template <typename Scalar>
Status make_record(const Calibration<Scalar>& c, std::uint32_t device_id, std::uint32_t sensor_id,
                   CalibrationRecord& out, const MagCalibration<Scalar>* mag,
                   const TemperatureModel<Scalar>* temperature, Bound* bound) {
  CalibrationRecord r;
  r.device_id = device_id;
  r.sensor_id = sensor_id;
  Calibration<float>& f = r.calibration;
  f.quality = c.quality;
  f.sample_rate_hz = static_cast<float>(c.sample_rate_hz);
  // A temperature note that is not a plausible temperature is dropped, not the calibration.
  f.has_temperature = c.has_temperature && temperature_plausible(c.temperature_c);
  f.temperature_c = f.has_temperature ? static_cast<float>(c.temperature_c) : 0.0f;
  if (succeeded(c.accel.status)) {
    AccelCalibration<float>& a = f.accel;
    if (!to_float<Scalar>(c.accel.params, a.params) || !to_float<Scalar>(c.accel.sigma, a.sigma))
      return Status::kInvalidArgument;
    a.residual_rms = static_cast<float>(c.accel.residual_rms);
    a.poses = c.accel.poses;
    a.iterations = c.accel.iterations;
    a.status = Status::kOk;
    r.parts = static_cast<std::uint16_t>(r.parts | kRecordAccel);
  }
  if (succeeded(c.gyro.status)) {
    GyroCalibration<float>& g = f.gyro;
    if (!to_float<Scalar>(c.gyro.params, g.params) || !to_float<Scalar>(c.gyro.sigma, g.sigma))
      return Status::kInvalidArgument;
    g.residual_rms = static_cast<float>(c.gyro.residual_rms);
    g.moves = c.gyro.moves;
    g.iterations = c.gyro.iterations;
    g.bias_refined = c.gyro.bias_refined;
    g.status = Status::kOk;
    r.parts = static_cast<std::uint16_t>(r.parts | kRecordGyro);
  }
  if (mag != nullptr && succeeded(mag->status)) {
    r.mag = mag_to_float(*mag);
    r.parts = static_cast<std::uint16_t>(r.parts | kRecordMag);
  }
  if (bound != nullptr) *bound = Bound::kNone;
  if (!record_ok(r)) return Status::kInvalidArgument;
  const Bound b = record_bound(r);
  if (bound != nullptr) *bound = b;
  if (b != Bound::kNone) return Status::kImplausible;
  if (temperature != nullptr)
    add_temperature(r, temperature_to_float(*temperature, r.parts), bound);
  out = r;
  return Status::kOk;
}

template Status make_record<float>(const Calibration<float>&, std::uint32_t, std::uint32_t,
                                   CalibrationRecord&, const MagCalibration<float>*,
                                   const TemperatureModel<float>*, Bound*);
template Status make_record<double>(const Calibration<double>&, std::uint32_t, std::uint32_t,
                                    CalibrationRecord&, const MagCalibration<double>*,
                                    const TemperatureModel<double>*, Bound*);

Status encode_record(const CalibrationRecord& r, std::uint8_t* out, std::size_t capacity,
                     std::size_t* size) {
  if (out == nullptr || !record_ok(r)) return Status::kInvalidArgument;
  if (record_bound(r) != Bound::kNone) return Status::kImplausible;
  const Calibration<float>& c = r.calibration;
  Writer w(out, capacity);
  for (std::uint8_t b : kMagic) w.u8(b);
  w.u8(kRecordVersion);
  w.u8(0);
  w.u16(0);  // length, filled in below
  w.u32(r.device_id);
  w.u32(r.sensor_id);
  w.u16(r.parts);
  w.u16(0);
  w.u8(kTagInfo);
  w.u8(0);
  w.u16(kInfoBytes);
  w.u8(static_cast<std::uint8_t>(c.quality));
  w.u8(c.has_temperature ? 1 : 0);
  w.u16(0);
  w.f32(c.temperature_c);
  w.f32(c.sample_rate_hz);
  if (r.parts & kRecordAccel) {
    const AccelCalibration<float>& a = c.accel;
    w.u8(kTagAccel);
    w.u8(0);
    w.u16(kAccelBytes);
    w.u16(static_cast<std::uint16_t>(a.poses));
    w.u16(0);
    write_block(w, a.params, a.sigma, a.residual_rms);
  }
  if (r.parts & kRecordGyro) {
    const GyroCalibration<float>& g = c.gyro;
    w.u8(kTagGyro);
    w.u8(0);
    w.u16(kGyroBytes);
    w.u16(static_cast<std::uint16_t>(g.moves));
    w.u8(g.bias_refined ? 1 : 0);
    w.u8(0);
    write_block(w, g.params, g.sigma, g.residual_rms);
  }
  if (r.parts & kRecordMag) write_mag(w, r.mag);
  if (r.parts & kRecordTemperature) write_temperature(w, r.temperature);
  const std::size_t n = w.pos() + kCrcBytes;
  if (n > capacity || n > kRecordMaxBytes) return Status::kCapacityExceeded;
  w.put_u16_at(6, static_cast<std::uint16_t>(n));
  w.u32(crc32(out, n - kCrcBytes));
  if (size != nullptr) *size = n;
  return Status::kOk;
}

Status decode_record(const std::uint8_t* data, std::size_t size, CalibrationRecord& out,
                     std::size_t* error_offset, Bound* bound) {
  if (data == nullptr) return Status::kInvalidArgument;
  // The header, in the order its fields can be trusted: magic, version, then the length (so a
  // truncation is told from corruption), then the CRC over everything, then the fields.
  for (std::size_t i = 0; i < 4; ++i) {
    if (i >= size) return fail(Status::kRecordTruncated, size, error_offset);
    if (data[i] != kMagic[i]) return fail(Status::kRecordBadMagic, i, error_offset);
  }
  if (size < 8) return fail(Status::kRecordTruncated, size, error_offset);
  const std::uint8_t version = data[4];
  if (version == 0 || version > kRecordVersion)
    return fail(Status::kRecordBadVersion, 4, error_offset);
  const std::size_t n = load_u16(data + 6);
  if (n < kRecordHeaderBytes + kSectionHeaderBytes + kInfoBytes + kCrcBytes || n > kRecordMaxBytes)
    return fail(Status::kRecordBadLength, 6, error_offset);
  if (size < n) return fail(Status::kRecordTruncated, size, error_offset);
  if (crc32(data, n - kCrcBytes) != load_u32(data + n - kCrcBytes))
    return fail(Status::kRecordBadChecksum, n - kCrcBytes, error_offset);

  CalibrationRecord r;
  r.version = version;
  if (data[5] != 0) return fail(Status::kRecordBadField, 5, error_offset);
  r.device_id = load_u32(data + 8);
  r.sensor_id = load_u32(data + 12);
  const std::uint16_t parts = load_u16(data + 16);
  if (load_u16(data + 18) != 0) return fail(Status::kRecordBadField, 18, error_offset);
  // Parts bits of a newer format are allowed: their sections are skipped below.
  r.parts = static_cast<std::uint16_t>(parts & kKnownParts);

  std::uint16_t seen = 0;                          // bit per known tag
  std::size_t payload_at[kLastKnownTag + 1] = {};  // of each known section
  const std::size_t end = n - kCrcBytes;
  std::size_t at = kRecordHeaderBytes;
  while (at < end) {
    if (end - at < kSectionHeaderBytes) return fail(Status::kRecordBadLength, at, error_offset);
    const std::uint8_t tag = data[at];
    if (tag == 0) return fail(Status::kRecordBadField, at, error_offset);
    if (data[at + 1] != 0) return fail(Status::kRecordBadField, at + 1, error_offset);
    const std::size_t length = load_u16(data + at + 2);
    const std::size_t payload = at + kSectionHeaderBytes;
    if (length > end - payload) return fail(Status::kRecordBadLength, at + 2, error_offset);
    const std::uint16_t bit = static_cast<std::uint16_t>(tag < 16 ? 1u << tag : 0u);
    if (tag <= kLastKnownTag && (seen & bit))
      return fail(Status::kRecordBadField, at, error_offset);
    seen = static_cast<std::uint16_t>(seen | bit);
    if (tag <= kLastKnownTag) payload_at[tag] = payload;
    Reader in(data, payload);
    switch (tag) {
      case kTagInfo:
        if (length < kInfoBytes) return fail(Status::kRecordBadLength, at + 2, error_offset);
        read_info(in, r.calibration);
        break;
      case kTagAccel:
        if (length < kAccelBytes) return fail(Status::kRecordBadLength, at + 2, error_offset);
        if (!(parts & kRecordAccel)) return fail(Status::kRecordBadField, at, error_offset);
        read_accel(in, r.calibration.accel);
        break;
      case kTagGyro:
        if (length < kGyroBytes) return fail(Status::kRecordBadLength, at + 2, error_offset);
        if (!(parts & kRecordGyro)) return fail(Status::kRecordBadField, at, error_offset);
        read_gyro(in, r.calibration.gyro);
        break;
      case kTagMag:
        if (length < kMagBytes) return fail(Status::kRecordBadLength, at + 2, error_offset);
        if (!(parts & kRecordMag)) return fail(Status::kRecordBadField, at, error_offset);
        read_mag(in, r.mag);
        break;
      case kTagTemperature:
        if (length < kTemperatureHeadBytes)
          return fail(Status::kRecordBadLength, at + 2, error_offset);
        if (!(parts & kRecordTemperature)) return fail(Status::kRecordBadField, at, error_offset);
        if (!read_temperature(in, length, parts, r.temperature))
          return fail(Status::kRecordBadLength, at + 2, error_offset);
        break;
      default:
        ++r.unknown_sections;
        break;
    }
    if (in.failed()) return fail(Status::kRecordBadField, in.bad(), error_offset);
    at = payload + length;
  }
  // Every known part announced has its section, and the info section is there.
  if (!(seen & (1u << kTagInfo))) return fail(Status::kRecordBadField, end, error_offset);
  if ((parts & kRecordAccel) && !(seen & (1u << kTagAccel)))
    return fail(Status::kRecordBadField, 16, error_offset);
  if ((parts & kRecordGyro) && !(seen & (1u << kTagGyro)))
    return fail(Status::kRecordBadField, 16, error_offset);
  if ((parts & kRecordMag) && !(seen & (1u << kTagMag)))
    return fail(Status::kRecordBadField, 16, error_offset);
  if ((parts & kRecordTemperature) && !(seen & (1u << kTagTemperature)))
    return fail(Status::kRecordBadField, 16, error_offset);
  // Every value within its physical bounds.
  bool in_model = false;
  const Bound b = record_bound_in(r, &in_model);
  if (bound != nullptr) *bound = b;
  if (b != Bound::kNone)
    return fail(Status::kRecordBadField, payload_at[bound_tag(b, in_model)], error_offset);
  out = r;
  return Status::kOk;
}

}  // namespace imucal
