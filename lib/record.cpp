// SPDX-License-Identifier: MIT
// The calibration record's encoder and validating decoder (format:
// include/imucal/store/record.hpp). One table of each section's fields (kInfoFields, ...) serves
// both: the decoder reads and checks through it, the encoder writes.
#include "imucal/store/record.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

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

// Each known section: the least payload length its fields take, and the part it belongs to (the
// info section: none).
struct KnownSection {
  std::uint16_t min_length;
  std::uint16_t part;
};
constexpr KnownSection kKnownSections[kLastKnownTag + 1] = {
    {0, 0},
    {kInfoBytes, 0},
    {kAccelBytes, kRecordAccel},
    {kGyroBytes, kRecordGyro},
    {kMagBytes, kRecordMag},
    {kTemperatureHeadBytes, kRecordTemperature}};

// ---- The fields of each section, in the order of their bytes (record.hpp) --------------------
// One table per section serves both directions: the decoder reads and checks each field into the
// section's struct, the encoder writes it from there.

// What a field is. The first kinds are reals (IEEE-754 binary32), each within its range
// (kRanges): NaN and the infinities are within none.
enum Kind : std::uint8_t {
  kFinite,       // any finite value
  kNonNegative,  // sigmas, residuals, the fit error
  kPositive,     // accelerometer scales, the field strength
  kNonZero,      // gyro scales (negative: the axis points the other way)
  kZeroOnly,     // (kNote of an unknown temperature)
  kCelsius,      // temperatures: -100..200 deg C (plausibility.hpp)
  kRate,         // the sample rate: 0..1e6 Hz (plausibility.hpp)
  kFraction,     // the magnetometer's coverage: 0..1
  kDip,          // the field's inclination: -90..90 degrees
  kNote,  // the temperature at calibration: kCelsius if the flag before says it is known, else 0
  kTop,   // kCelsius, and not below the real before it (the top of a range)
  kLastReal = kTop,
  // Not reals.
  kSoftIron,    // a 3x3 row by row (column-major in memory), finite, det > 0: a soft iron that
                // mirrors space (or collapses it) is not a calibration
  kCount,       // u16 into an int, at least n
  kQuality,     // u8 into a Quality, at most kGood
  kFlag,        // u8 into a bool: bit 0, no other
  kAligned,     // u8, bit 0 (no other): the magnetometer's alignment status, kOk or kNotStarted
  kModelFlags,  // u8 of the temperature model (the struct): bits 0 and 1 (kRecordAccel,
                // kRecordGyro) say whose coefficients are usable, one at least in the record
  kReserved,    // n bytes of zeros
};
struct Range {
  float lo, hi;
  bool nonzero;
};
constexpr float kFloatMax = std::numeric_limits<float>::max();
constexpr Range kRanges[] = {{-kFloatMax, kFloatMax, false},
                             {0.0f, kFloatMax, false},
                             {0.0f, kFloatMax, true},
                             {-kFloatMax, kFloatMax, true},
                             {0.0f, 0.0f, false},
                             {static_cast<float>(bounds::kMinTemperatureC),
                              static_cast<float>(bounds::kMaxTemperatureC), false},
                             {0.0f, static_cast<float>(bounds::kMaxSampleRateHz), false},
                             {0.0f, 1.0f, false},
                             {-90.0f, 90.0f, false}};
static_assert(sizeof kRanges / sizeof kRanges[0] == kDip + 1, "a range for every plain real");

bool meets(float v, Kind k) {
  const Range& r = kRanges[k];
  return bounds::in_range(v, r.lo, r.hi) && !(r.nonzero && bounds::magnitude_bits(v) == 0u);
}
bool all_meet(const float* v, int n, Kind k) {
  for (int i = 0; i < n; ++i)
    if (!meets(v[i], k)) return false;
  return true;
}

// A field: its kind, n (reals: how many, in a row in memory; kCount: the least; kReserved:
// bytes) and where its value lives: `at` bytes into the section's struct.
struct Field {
  std::uint16_t at;
  Kind kind;
  std::uint8_t n;
};

// The structs are read and written through offsetof: standard layout, and an Eigen vector is its
// floats and nothing else.
static_assert(std::is_standard_layout<CalibrationRecord>::value, "offsetof");
static_assert(sizeof(AccelVector<float>) == kAccelParams * sizeof(float) &&
                  sizeof(GyroVector<float>) == kGyroParams * sizeof(float) &&
                  sizeof(Matrix3<float>) == 9 * sizeof(float) &&
                  sizeof(MagSymVector<float>) == kMagSymEntries * sizeof(float),
              "an Eigen vector's floats are the vector");
// The offset of the k-th float of a member that starts `member` bytes into its struct.
constexpr std::uint16_t at(std::size_t member, int k = 0) {
  return static_cast<std::uint16_t>(member + sizeof(float) * static_cast<std::size_t>(k));
}

using Info = Calibration<float>;
constexpr Field kInfoFields[] = {{at(offsetof(Info, quality)), kQuality, 1},
                                 {at(offsetof(Info, has_temperature)), kFlag, 1},
                                 {0, kReserved, 2},
                                 {at(offsetof(Info, temperature_c)), kNote, 1},
                                 {at(offsetof(Info, sample_rate_hz)), kRate, 1}};

using Accel = AccelCalibration<float>;
static_assert(kAlphaYz == 0 && kScaleX == 3 && kBiasX == 6, "misalignments, scales, biases");
constexpr Field kAccelFields[] = {{at(offsetof(Accel, poses)), kCount, kAccelMinPoses},
                                  {0, kReserved, 2},
                                  {at(offsetof(Accel, params)), kFinite, 3},
                                  {at(offsetof(Accel, params), kScaleX), kPositive, 3},
                                  {at(offsetof(Accel, params), kBiasX), kFinite, 3},
                                  {at(offsetof(Accel, sigma)), kNonNegative, kAccelParams},
                                  {at(offsetof(Accel, residual_rms)), kNonNegative, 1}};

using Gyro = GyroCalibration<float>;
static_assert(kGammaYz == 0 && kGyroScaleX == 6 && kGyroBiasX == 9,
              "misalignments, scales, biases");
constexpr Field kGyroFields[] = {{at(offsetof(Gyro, moves)), kCount, 1},
                                 {at(offsetof(Gyro, bias_refined)), kFlag, 1},
                                 {0, kReserved, 1},
                                 {at(offsetof(Gyro, params)), kFinite, 6},
                                 {at(offsetof(Gyro, params), kGyroScaleX), kNonZero, 3},
                                 {at(offsetof(Gyro, params), kGyroBiasX), kFinite, 3},
                                 {at(offsetof(Gyro, sigma)), kNonNegative, kGyroParams},
                                 {at(offsetof(Gyro, residual_rms)), kNonNegative, 1}};

using Mag = MagCalibration<float>;
constexpr Field kMagFields[] = {{at(offsetof(Mag, samples)), kCount, 1},
                                {at(offsetof(Mag, quality)), kQuality, 1},
                                {at(offsetof(Mag, alignment_status)), kAligned, 1},
                                {at(offsetof(Mag, soft_iron)), kSoftIron, 9},
                                {at(offsetof(Mag, hard_iron)), kFinite, 3},
                                {at(offsetof(Mag, hard_iron_sigma)), kNonNegative, 3},
                                {at(offsetof(Mag, soft_iron_sigma)), kNonNegative, kMagSymEntries},
                                {at(offsetof(Mag, field_ut)), kPositive, 1},
                                {at(offsetof(Mag, fit_error_pct)), kNonNegative, 1},
                                {at(offsetof(Mag, coverage)), kFraction, 1},
                                {at(offsetof(Mag, dip_deg)), kDip, 1},
                                {at(offsetof(Mag, dip_sigma_deg)), kNonNegative, 1}};

// The temperature model after its order (which sets the payload's length), then each sensor's
// coefficients (b2 and its sigma only in a quadratic model): those of a sensor the record does
// not hold are read and left out; an unusable sensor's are zeros.
using Model = TemperatureModel<float>;
static_assert(kRecordAccel == 1u && kRecordGyro == 2u, "the temperature flags' bits");
constexpr Field kModelFields[] = {{0, kModelFlags, 1},
                                  {at(offsetof(Model, rests)), kCount, 1},
                                  {at(offsetof(Model, reference_c)), kCelsius, 1},
                                  {at(offsetof(Model, min_c)), kCelsius, 1},
                                  {at(offsetof(Model, max_c)), kTop, 1}};
using Bias = TemperatureBias<float>;
constexpr Field kLinearBiasFields[] = {{at(offsetof(Bias, b0)), kFinite, 3},
                                       {at(offsetof(Bias, b1)), kFinite, 3},
                                       {at(offsetof(Bias, b0_sigma)), kNonNegative, 3},
                                       {at(offsetof(Bias, b1_sigma)), kNonNegative, 3}};
constexpr Field kQuadraticBiasFields[] = {{at(offsetof(Bias, b0)), kFinite, 3},
                                          {at(offsetof(Bias, b1)), kFinite, 3},
                                          {at(offsetof(Bias, b2)), kFinite, 3},
                                          {at(offsetof(Bias, b0_sigma)), kNonNegative, 3},
                                          {at(offsetof(Bias, b1_sigma)), kNonNegative, 3},
                                          {at(offsetof(Bias, b2_sigma)), kNonNegative, 3}};
// A sensor's coefficients in a model of the given order (1 or 2): the table and its length.
const Field* bias_fields(int order, int* n) {
  *n = order == 2 ? 6 : 4;
  return order == 2 ? kQuadraticBiasFields : kLinearBiasFields;
}

template <class T>
T* member(void* base, std::uint16_t at) {
  return static_cast<T*>(static_cast<void*>(static_cast<unsigned char*>(base) + at));
}
template <class T>
const T& member(const void* base, std::uint16_t at) {
  return *static_cast<const T*>(
      static_cast<const void*>(static_cast<const unsigned char*>(base) + at));
}

// ---- Bytes ---------------------------------------------------------------------------------

// Reads a section's payload field by field, each checked as it is read; remembers the first field
// that is wrong (its offset in the record) and reads on. Reads past the payload never happen: the
// caller checks its length first.
class Reader {
 public:
  // parts: the record's parts field (the temperature model needs one of its sensors).
  Reader(const std::uint8_t* record, std::size_t at, unsigned parts)
      : rec_(record), pos_(at), parts_(parts) {}

  // The temperature model's order: 1 or 2.
  void order(int& v) {
    v = static_cast<int>(take(1));
    check(v == 1 || v == 2, 1);
  }
  template <std::size_t N>
  void fields(const Field (&f)[N], void* base) {
    fields(f, static_cast<int>(N), base);
  }
  void fields(const Field* f, int n, void* base);
  unsigned model_flags() const { return flags_; }  // the temperature model's, once read

  bool failed() const { return bad_ != kNone; }
  std::size_t bad() const { return bad_; }

 private:
  static constexpr std::size_t kNone = ~std::size_t(0);
  std::uint32_t take(int size) {
    std::uint32_t v = 0;
    for (int i = 0; i < size; ++i) v |= std::uint32_t{rec_[pos_++]} << (8 * i);
    return v;
  }
  // The field of `size` bytes just read is right if ok.
  void check(bool ok, int size) {
    if (!ok && !failed()) bad_ = pos_ - static_cast<std::size_t>(size);
  }
  float real(Kind k) {
    const std::uint32_t bits = take(4);
    float v;
    std::memcpy(&v, &bits, sizeof v);
    bool ok;
    if (k == kNote)
      ok = meets(v, (flags_ & 1u) != 0 ? kCelsius : kZeroOnly);
    else if (k == kTop)  // the real before it checked already (a NaN there is the first wrong)
      ok = meets(v, kCelsius) && bounds::at_most(last_, v);
    else
      ok = meets(v, k);
    check(ok, 4);
    last_ = v;
    return v;
  }

  const std::uint8_t* rec_;
  std::size_t pos_;
  unsigned parts_;
  unsigned flags_ = 0;  // the last flags read
  float last_ = 0.0f;   // the last real read
  std::size_t bad_ = kNone;
};

void Reader::fields(const Field* f, int n, void* base) {
  for (; n > 0; --n, ++f) {
    if (f->kind <= kLastReal) {
      float* v = member<float>(base, f->at);
      for (int i = 0; i < f->n; ++i) v[i] = real(f->kind);
      continue;
    }
    std::uint32_t v = f->kind == kReserved ? take(f->n) : f->kind == kCount ? take(2) : 0;
    switch (f->kind) {
      case kSoftIron: {
        Matrix3<float>& s = *member<Matrix3<float>>(base, f->at);
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) s(r, c) = real(kFinite);
        check(bounds::positive(bounds::determinant(s)), 36);
        break;
      }
      case kCount:
        *member<int>(base, f->at) = static_cast<int>(v);
        check(v >= f->n, 2);
        break;
      case kReserved:
        check(v == 0, f->n);
        break;
      default:  // one byte
        v = take(1);
        flags_ = v;
        if (f->kind == kQuality) {
          check(v <= static_cast<std::uint32_t>(Quality::kGood), 1);
          *member<Quality>(base, f->at) = static_cast<Quality>(v);
        } else if (f->kind == kModelFlags) {
          check((v & ~3u) == 0 && (v & parts_) != 0, 1);
        } else {
          check((v & ~1u) == 0, 1);
          if (f->kind == kFlag)
            *member<bool>(base, f->at) = v != 0;
          else  // kAligned
            *member<Status>(base, f->at) = v != 0 ? Status::kOk : Status::kNotStarted;
        }
        break;
    }
  }
}

// Writes a record's bytes (record_ok() has checked its values); bytes past the capacity are
// counted, not written.
class Writer {
 public:
  Writer(std::uint8_t* out, std::size_t capacity) : out_(out), capacity_(capacity) {}

  void put(std::uint32_t v, int size) {
    for (int i = 0; i < size; ++i, ++pos_)
      if (pos_ < capacity_) out_[pos_] = static_cast<std::uint8_t>((v >> (8 * i)) & 0xFFu);
  }
  void section(Tag tag, std::uint16_t length) {
    put(tag, 1);
    put(0, 1);
    put(length, 2);
  }
  template <std::size_t N>
  void fields(const Field (&f)[N], const void* base) {
    fields(f, static_cast<int>(N), base);
  }
  void fields(const Field* f, int n, const void* base);
  void put_u16_at(std::size_t at, std::uint16_t v) {
    if (at + 1 < capacity_) {
      out_[at] = static_cast<std::uint8_t>(v & 0xFFu);
      out_[at + 1] = static_cast<std::uint8_t>(v >> 8);
    }
  }
  std::size_t pos() const { return pos_; }

 private:
  void real(float v) {
    std::uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    put(bits, 4);
  }

  std::uint8_t* out_;
  std::size_t capacity_;
  std::size_t pos_ = 0;
};

void Writer::fields(const Field* f, int n, const void* base) {
  for (; n > 0; --n, ++f) {
    if (f->kind <= kLastReal) {
      const float* v = &member<float>(base, f->at);
      for (int i = 0; i < f->n; ++i) real(v[i]);
      continue;
    }
    switch (f->kind) {
      case kSoftIron: {
        const Matrix3<float>& s = member<Matrix3<float>>(base, f->at);
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) real(s(r, c));
        break;
      }
      case kCount:
        put(static_cast<std::uint32_t>(member<int>(base, f->at)), 2);
        break;
      case kReserved:
        put(0, f->n);
        break;
      case kQuality:
        put(static_cast<std::uint32_t>(member<Quality>(base, f->at)), 1);
        break;
      case kFlag:
        put(member<bool>(base, f->at) ? 1u : 0u, 1);
        break;
      case kAligned:
        put(succeeded(member<Status>(base, f->at)) ? 1u : 0u, 1);
        break;
      default: {  // kModelFlags
        const Model& t = member<Model>(base, f->at);
        put((succeeded(t.accel.status) ? 1u : 0u) | (succeeded(t.gyro.status) ? 2u : 0u), 1);
        break;
      }
    }
  }
}

using detail::load_u16;
using detail::load_u32;

// ---- Validity of a record's values for the encoder (the decoder's checks, on values) ----------

template <class V>
bool all_finite_f(const V& v) {
  return all_meet(v.data(), static_cast<int>(v.size()), kFinite);
}
template <class V>
bool all_sigmas_ok(const V& v) {
  return all_meet(v.data(), static_cast<int>(v.size()), kNonNegative);
}

bool accel_ok(const AccelCalibration<float>& a) {
  const float* p = a.params.data();
  return a.poses >= kAccelMinPoses && a.poses <= 0xFFFF && all_meet(p, kScaleX, kFinite) &&
         all_meet(p + kScaleX, 3, kPositive) && all_meet(p + kBiasX, 3, kFinite) &&
         all_sigmas_ok(a.sigma) && meets(a.residual_rms, kNonNegative);
}
bool gyro_ok(const GyroCalibration<float>& g) {
  const float* p = g.params.data();
  return g.moves >= 1 && g.moves <= 0xFFFF && all_meet(p, kGyroScaleX, kFinite) &&
         all_meet(p + kGyroScaleX, 3, kNonZero) && all_meet(p + kGyroBiasX, 3, kFinite) &&
         all_sigmas_ok(g.sigma) && meets(g.residual_rms, kNonNegative);
}
bool mag_ok(const MagCalibration<float>& m) {
  return m.samples >= 1 && m.samples <= 0xFFFF && m.quality <= Quality::kGood &&
         all_finite_f(m.soft_iron) && bounds::positive(bounds::determinant(m.soft_iron)) &&
         all_finite_f(m.hard_iron) && all_sigmas_ok(m.hard_iron_sigma) &&
         all_sigmas_ok(m.soft_iron_sigma) && meets(m.field_ut, kPositive) &&
         meets(m.fit_error_pct, kNonNegative) && meets(m.coverage, kFraction) &&
         meets(m.dip_deg, kDip) && meets(m.dip_sigma_deg, kNonNegative);
}
bool temperature_bias_ok(const TemperatureBias<float>& b, int order) {
  return all_finite_f(b.b0) && all_finite_f(b.b1) && all_finite_f(b.b2) &&
         all_sigmas_ok(b.b0_sigma) && all_sigmas_ok(b.b1_sigma) && all_sigmas_ok(b.b2_sigma) &&
         (order == 2 || (b.b2.isZero(0.0f) && b.b2_sigma.isZero(0.0f)));
}
// A sensor's coefficients only with the sensor: bounded through its matrix, applied to it alone.
// The range of its temperatures is a bound (record_bound(): kImplausible), not the format's.
bool temperature_model_ok(const TemperatureModel<float>& t, std::uint16_t parts) {
  const bool a = succeeded(t.accel.status), g = succeeded(t.gyro.status);
  return (t.order == 1 || t.order == 2) && (a || g) && (!a || (parts & kRecordAccel)) &&
         (!g || (parts & kRecordGyro)) && t.rests >= 1 && t.rests <= 0xFFFF &&
         bounds::is_finite(t.reference_c) && bounds::is_finite(t.min_c) &&
         bounds::is_finite(t.max_c) && (!a || temperature_bias_ok(t.accel, t.order)) &&
         (!g || temperature_bias_ok(t.gyro, t.order));
}
bool record_ok(const CalibrationRecord& r) {
  const Calibration<float>& c = r.calibration;
  return (r.parts & ~kKnownParts) == 0 && r.parts != 0 && c.quality <= Quality::kGood &&
         meets(c.temperature_c, c.has_temperature ? kCelsius : kZeroOnly) &&
         bounds::is_finite(c.sample_rate_hz) && (!(r.parts & kRecordAccel) || accel_ok(c.accel)) &&
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
  if (!meets(c.sample_rate_hz, kRate)) return Bound::kSampleRate;
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

template <typename Scalar, class V>
bool to_float(const V& in, Eigen::Matrix<float, V::RowsAtCompileTime, 1>& out) {
  for (int i = 0; i < in.size(); ++i) {
    out(i) = static_cast<float>(in(i));
    if (!bounds::is_finite(out(i))) return false;
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

// A record is its bytes: standard layout, every member a number, an enum or a fixed-size Eigen
// matrix of floats (the codec's tables read and write them through their offsets). So its
// defaults are zeros but for the few set below, and a copy is one memcpy, instead of member-wise
// code for some 160 fields. test_record.cpp holds the defaults to the members' own initialisers
// (Record.DefaultsAreTheMembersOwn): a new member whose default is not zero fails it.
CalibrationRecord::CalibrationRecord(Blank)
    : calibration{{AccelVector<float>(), AccelVector<float>()},
                  {GyroVector<float>(), GyroVector<float>()}},
      mag{Status::kNotStarted,
          Matrix3<float>(),
          Vector3<float>(),
          Vector3<float>(),
          MagSymVector<float>(),
          0.0f,
          0.0f,
          0.0f,
          0,
          0,
          Quality::kNone,
          Status::kNotStarted,
          0.0f,
          0.0f,
          Vector3<float>(),
          Vector3<float>()},
      temperature{1,
                  0.0f,
                  0.0f,
                  0.0f,
                  0,
                  {Vector3<float>(), Vector3<float>(), Vector3<float>(), Vector3<float>(),
                   Vector3<float>(), Vector3<float>()},
                  {Vector3<float>(), Vector3<float>(), Vector3<float>(), Vector3<float>(),
                   Vector3<float>(), Vector3<float>()}} {}
// The member initialisers' values (record.hpp, calibration.hpp, mag_model.hpp,
// temperature_model.hpp): every one zero (0, false, Quality::kNone, a zero matrix) but these.
CalibrationRecord::CalibrationRecord() : CalibrationRecord(Blank{}) {
  std::memset(static_cast<void*>(this), 0, sizeof *this);
  version = kRecordVersion;
  calibration.accel.status = Status::kNotStarted;
  calibration.gyro.status = Status::kNotStarted;
  mag.status = Status::kNotStarted;
  for (int i = 0; i < 3; ++i) mag.soft_iron(i, i) = 1.0f;
  mag.alignment_status = Status::kNotStarted;
  temperature.order = 1;
  temperature.accel.status = Status::kNotStarted;
  temperature.gyro.status = Status::kNotStarted;
}
CalibrationRecord::CalibrationRecord(const CalibrationRecord& other) : CalibrationRecord(Blank{}) {
  std::memcpy(static_cast<void*>(this), static_cast<const void*>(&other), sizeof other);
}
CalibrationRecord& CalibrationRecord::operator=(const CalibrationRecord& other) {
  if (this != &other)
    std::memcpy(static_cast<void*>(this), static_cast<const void*>(&other), sizeof other);
  return *this;
}

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
  // A note that is not a plausible sample rate or temperature is dropped, not the calibration
  // (a rate of 0 is unknown).
  f.sample_rate_hz = c.sample_rate_hz >= Scalar(0) &&
                             c.sample_rate_hz <= static_cast<Scalar>(bounds::kMaxSampleRateHz)
                         ? static_cast<float>(c.sample_rate_hz)
                         : 0.0f;
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
  for (std::uint8_t b : kMagic) w.put(b, 1);
  w.put(kRecordVersion, 1);
  w.put(0, 1);
  w.put(0, 2);  // length, filled in below
  w.put(r.device_id, 4);
  w.put(r.sensor_id, 4);
  w.put(r.parts, 2);
  w.put(0, 2);
  w.section(kTagInfo, kInfoBytes);
  w.fields(kInfoFields, &c);
  if (r.parts & kRecordAccel) {
    w.section(kTagAccel, kAccelBytes);
    w.fields(kAccelFields, &c.accel);
  }
  if (r.parts & kRecordGyro) {
    w.section(kTagGyro, kGyroBytes);
    w.fields(kGyroFields, &c.gyro);
  }
  if (r.parts & kRecordMag) {
    w.section(kTagMag, kMagBytes);
    w.fields(kMagFields, &r.mag);
  }
  if (r.parts & kRecordTemperature) {
    const Model& t = r.temperature;
    w.section(kTagTemperature, temperature_bytes(t.order));
    w.put(static_cast<std::uint32_t>(t.order), 1);
    w.fields(kModelFields, &t);
    int count = 0;
    const Field* bias = bias_fields(t.order, &count);
    const Bias zero{};  // an unusable sensor's coefficients
    w.fields(bias, count, succeeded(t.accel.status) ? &t.accel : &zero);
    w.fields(bias, count, succeeded(t.gyro.status) ? &t.gyro : &zero);
  }
  const std::size_t n = w.pos() + kCrcBytes;
  if (n > capacity || n > kRecordMaxBytes) return Status::kCapacityExceeded;
  w.put_u16_at(6, static_cast<std::uint16_t>(n));
  w.put(crc32(out, n - kCrcBytes), 4);
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
    Reader in(data, payload, parts);
    if (tag > kLastKnownTag) {
      ++r.unknown_sections;
      at = payload + length;
      continue;
    }
    const std::uint16_t bit = static_cast<std::uint16_t>(1u << tag);
    if (seen & bit) return fail(Status::kRecordBadField, at, error_offset);
    seen = static_cast<std::uint16_t>(seen | bit);
    payload_at[tag] = payload;
    const KnownSection& known = kKnownSections[tag];
    if (length < known.min_length) return fail(Status::kRecordBadLength, at + 2, error_offset);
    if (known.part & ~parts) return fail(Status::kRecordBadField, at, error_offset);
    switch (tag) {
      case kTagInfo:
        in.fields(kInfoFields, &r.calibration);
        break;
      case kTagAccel:
        in.fields(kAccelFields, &r.calibration.accel);
        r.calibration.accel.status = Status::kOk;
        break;
      case kTagGyro:
        in.fields(kGyroFields, &r.calibration.gyro);
        r.calibration.gyro.status = Status::kOk;
        break;
      case kTagMag:
        in.fields(kMagFields, &r.mag);
        r.mag.status = Status::kOk;
        break;
      default: {  // kTagTemperature
        Model& t = r.temperature;
        in.order(t.order);
        if (in.failed()) break;
        if (length < temperature_bytes(t.order))
          return fail(Status::kRecordBadLength, at + 2, error_offset);
        in.fields(kModelFields, &t);
        int count = 0;
        const Field* fields = bias_fields(t.order, &count);
        // The coefficients of a sensor not in the record: read, checked, left out (so unset).
        Bias ignored{Vector3<float>(), Vector3<float>(), Vector3<float>(),
                     Vector3<float>(), Vector3<float>(), Vector3<float>()};
        Bias* const biases[2] = {&t.accel, &t.gyro};
        for (unsigned k = 0; k < 2; ++k) {
          const bool usable = (in.model_flags() & parts & (1u << k)) != 0;
          in.fields(fields, count, usable ? biases[k] : &ignored);
          if (usable) biases[k]->status = Status::kOk;
        }
        break;
      }
    }
    if (in.failed()) return fail(Status::kRecordBadField, in.bad(), error_offset);
    at = payload + length;
  }
  // Every known part announced has its section, and the info section is there.
  if (!(seen & (1u << kTagInfo))) return fail(Status::kRecordBadField, end, error_offset);
  for (int tag = kTagAccel; tag <= kLastKnownTag; ++tag)
    if ((parts & kKnownSections[tag].part) && !(seen & (1u << tag)))
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
