// SPDX-License-Identifier: MIT
// Allan variance and the noise-term fit (allan.hpp) against simulated noise of known truth:
// white noise, rate random walk, angle quantisation and flicker (bias instability), float and
// double, the streaming accumulator against the overlapping estimate on the same samples, bad
// input, and the real xsens recording's initial rest. Every tolerance comes from the estimate's
// own sigma or confidence interval.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <limits>
#include <vector>

#include "imucal/noise/allan.hpp"
#include "imucal/sim/random.hpp"
#include "support/xsens_reader.hpp"

namespace imucal {
namespace {

#ifdef IMUCAL_SMALL_TARGET
constexpr std::size_t kScale = 16;  // the boards have 2-4 MB and run under an emulator
#else
constexpr std::size_t kScale = 1;
#endif

constexpr double kDt = 0.01;  // 100 Hz
constexpr int kCapacity = 64;

// Samples as rows of 3 doubles (sample i, axis a at v[3 i + a]).
struct Series {
  std::vector<double> v;
  std::size_t n() const { return v.size() / 3; }
  template <typename Scalar>
  std::vector<Scalar> as() const {
    std::vector<Scalar> out(v.size());
    for (std::size_t i = 0; i < v.size(); ++i) out[i] = static_cast<Scalar>(v[i]);
    return out;
  }
};

// White rate noise of density n_density[a] (unit sqrt(s)) about `offset` (raw counts' level).
Series white(std::size_t n, const double (&density)[3], double offset, std::uint64_t seed) {
  sim::Random rng(seed);
  Series s;
  s.v.resize(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t a = 0; a < 3; ++a)
      s.v[3 * i + a] = offset + density[a] / std::sqrt(kDt) * rng.normal();
  }
  return s;
}

// Adds a rate random walk of coefficient k (unit / sqrt(s)) on every axis.
void add_random_walk(Series& s, double k, std::uint64_t seed) {
  sim::Random rng(seed);
  double b[3] = {0, 0, 0};
  for (std::size_t i = 0; i < s.n(); ++i) {
    for (std::size_t a = 0; a < 3; ++a) {
      s.v[3 * i + a] += b[a];
      b[a] += k * std::sqrt(kDt) * rng.normal();
    }
  }
}

// Angle read out in steps of q (a pulse-counting sensor) with subtractive dither (as a ring-laser
// gyro's dither makes its pulses): the rate is the difference of the read angle over dt, the
// read-out error is uniform and white in angle: AVAR = 3 Q^2 / tau^2, Q = q / sqrt(12).
void quantise_angle(Series& s, double q, std::uint64_t seed) {
  sim::Random rng(seed);
  double angle[3] = {0, 0, 0}, shown[3] = {0, 0, 0};
  for (std::size_t i = 0; i < s.n(); ++i) {
    for (std::size_t a = 0; a < 3; ++a) {
      angle[a] += s.v[3 * i + a] * kDt;
      const double d = q * rng.uniform(-0.5, 0.5);
      const double r = q * std::floor((angle[a] + d) / q + 0.5) - d;
      s.v[3 * i + a] = (r - shown[a]) / kDt;
      shown[a] = r;
    }
  }
}

// Flicker (bias instability) as a sum of first-order Gauss-Markov processes, equal variance s2
// each, time constants log-spaced (4 per decade) from t_lo to t_hi: a 1/f spectrum between, so a
// flat Allan deviation for t_lo << tau << t_hi.
struct Flicker {
  std::vector<double> tc;
  double s2 = 0;
  // The exact Allan variance of the sum (the Gauss-Markov formula, summed).
  double avar(double tau) const {
    double v = 0;
    for (const double t : tc) {
      const double r = tau / t;
      v += 2 * s2 * t / tau * (1 - 1 / (2 * r) * (3 - 4 * std::exp(-r) + std::exp(-2 * r)));
    }
    return v;
  }
};

Flicker add_flicker(Series& s, double t_lo, double t_hi, double s2, std::uint64_t seed) {
  Flicker f;
  f.s2 = s2;
  for (double t = t_lo; t <= t_hi * 1.0001; t *= std::pow(10.0, 0.25)) f.tc.push_back(t);
  sim::Random rng(seed);
  std::vector<double> x(3 * f.tc.size(), 0.0);
  for (std::size_t j = 0; j < f.tc.size(); ++j) {
    for (std::size_t a = 0; a < 3; ++a) x[3 * j + a] = std::sqrt(s2) * rng.normal();  // stationary
  }
  for (std::size_t i = 0; i < s.n(); ++i) {
    for (std::size_t j = 0; j < f.tc.size(); ++j) {
      const double phi = std::exp(-kDt / f.tc[j]);
      const double w = std::sqrt(s2 * (1 - phi * phi));
      for (std::size_t a = 0; a < 3; ++a) {
        s.v[3 * i + a] += x[3 * j + a];
        x[3 * j + a] = phi * x[3 * j + a] + w * rng.normal();
      }
    }
  }
  return f;
}

template <typename Scalar>
struct Overlapping {
  AllanPoint<Scalar> pts[kCapacity];
  int n = 0;
  Status status = Status::kOk;
};

template <typename Scalar>
void overlapping(const Series& s, Overlapping<Scalar>& o, int per_decade = 8) {
  if constexpr (sizeof(Scalar) == sizeof(double)) {  // no copy: the boards' RAM is small
    o.status = overlapping_allan<Scalar>(s.v.data(), s.n(), 3, static_cast<Scalar>(kDt), per_decade,
                                         o.pts, kCapacity, o.n);
  } else {
    const std::vector<Scalar> v = s.as<Scalar>();
    o.status = overlapping_allan<Scalar>(v.data(), s.n(), 3, static_cast<Scalar>(kDt), per_decade,
                                         o.pts, kCapacity, o.n);
  }
}

// The accumulator fed the same samples; its levels as points.
template <typename Scalar, int Levels>
int accumulate(const Series& s, AllanAccumulator<Scalar, Levels>& acc, AllanPoint<Scalar>* pts) {
  EXPECT_EQ(acc.start(static_cast<Scalar>(kDt)), Status::kOk);
  for (std::size_t i = 0; i < s.n(); ++i) {
    const Vector3<Scalar> x(static_cast<Scalar>(s.v[3 * i]), static_cast<Scalar>(s.v[3 * i + 1]),
                            static_cast<Scalar>(s.v[3 * i + 2]));
    EXPECT_EQ(acc.add(x), Status::kOk);
  }
  int n = 0;
  for (int k = 0; k < Levels; ++k) {
    if (acc.count(k) < 10) break;  // at least 10 differences, as the overlapping's n/10
    EXPECT_EQ(acc.result(k, pts[n]), Status::kOk);
    ++n;
  }
  return n;
}

// |value - truth| within `k` sigma, printing the numbers.
void expect_within(const char* what, const NoiseTerm<double>& t, double truth, double k = 3) {
  std::printf("  %-28s %.6g +- %.3g (truth %.6g, %.2f sigma)%s\n", what, t.value, t.sigma, truth,
              std::fabs(t.value - truth) / t.sigma, t.significant ? "" : " not significant");
  EXPECT_TRUE(t.significant) << what;
  EXPECT_LE(std::fabs(t.value - truth), k * t.sigma) << what;
}

template <typename Scalar>
NoiseTerm<double> as_double(const NoiseTerm<Scalar>& t) {
  return {static_cast<double>(t.value), static_cast<double>(t.sigma), t.significant};
}

TEST(AllanAccumulator, FixedSize) {
  // The device memory, for float: 56 bytes per octave plus 24.
  EXPECT_EQ(sizeof(AllanAccumulator<float, 16>), 920u);
  EXPECT_EQ(sizeof(AllanAccumulator<float, 8>), 472u);
}

// White noise of known density on raw-count offsets (33000): N within 3 sigma of the truth,
// from the overlapping estimate and from the streaming accumulator, in float and double.
template <typename Scalar>
void white_noise_recovered() {
  const double density[3] = {2.0, 0.5, 0.05};  // counts sqrt(s): 20, 5, 0.5 counts per sample
  const Series s = white(400000 / kScale, density, 33000.0, 11);
  static Overlapping<Scalar> o;
  overlapping(s, o);
  ASSERT_EQ(o.status, Status::kOk);
  ASSERT_GE(o.n, 20);
  static AllanAccumulator<Scalar, 16> acc;
  AllanPoint<Scalar> dev[16];
  const int nd = accumulate(s, acc, dev);
  ASSERT_GE(nd, 8);
  for (int a = 0; a < 3; ++a) {
    NoiseTerms<Scalar> f, g;
    ASSERT_EQ(fit_noise_terms(o.pts, o.n, a, f), Status::kOk);
    ASSERT_EQ(fit_noise_terms(dev, nd, a, g), Status::kOk);
    std::printf(" axis %d (chi2 %.1f / %d, device %.1f / %d)\n", a, static_cast<double>(f.chi2),
                f.dof, static_cast<double>(g.chi2), g.dof);
    expect_within("N overlapping", as_double(f.n), density[a]);
    expect_within("N accumulator", as_double(g.n), density[a]);
    // The classic read-out: the deviation at 1 s on the -1/2 line; 1 s has edf ~ n dt / 1 s.
    const double rel = 3 * std::sqrt(1.0 / (static_cast<double>(s.n()) * kDt));
    EXPECT_NEAR(static_cast<double>(f.classic_n), density[a], rel * density[a]);
    // Nothing else in the data: the other terms are absent or not significant.
    for (const NoiseTerms<Scalar>* t : {&f, &g}) {
      EXPECT_FALSE(t->q.significant);
      EXPECT_FALSE(t->b.significant);
      EXPECT_FALSE(t->k.significant);
    }
  }
}

TEST(Allan, WhiteNoiseDouble) { white_noise_recovered<double>(); }
TEST(Allan, WhiteNoiseFloat) { white_noise_recovered<float>(); }

// White noise plus a rate random walk: K within 3 sigma (and N still).
template <typename Scalar>
void random_walk_recovered() {
  const double density[3] = {0.01, 0.01, 0.01};
  // Visible above the white noise from tau ~ sqrt(3) N / K: 9 s (2 s on the boards' 250 s).
  const double k = kScale > 1 ? 0.008 : 0.002;
  Series s = white(400000 / kScale, density, 0.0, 21);
  add_random_walk(s, k, 22);
  static Overlapping<Scalar> o;
  overlapping(s, o);
  ASSERT_EQ(o.status, Status::kOk);
  for (int a = 0; a < 3; ++a) {
    NoiseTerms<Scalar> f;
    ASSERT_EQ(fit_noise_terms(o.pts, o.n, a, f), Status::kOk);
    std::printf(" axis %d (chi2 %.1f / %d)\n", a, static_cast<double>(f.chi2), f.dof);
    expect_within("K", as_double(f.k), k);
    expect_within("N", as_double(f.n), density[a]);
  }
}

TEST(Allan, RandomWalkDouble) { random_walk_recovered<double>(); }
TEST(Allan, RandomWalkFloat) { random_walk_recovered<float>(); }

// An angle read out in steps q: Q = q / sqrt(12) within 3 sigma (and the white noise under it).
template <typename Scalar>
void quantisation_recovered() {
  const double density[3] = {0.002, 0.002, 0.002};  // 0.02 per sample
  const double q = 0.001;  // angle step: Q dominates N up to tau = 3 Q^2 / N^2 = 0.06 s
  Series s = white(200000 / kScale, density, 0.5, 31);
  quantise_angle(s, q, 32);
  static Overlapping<Scalar> o;
  overlapping(s, o);
  ASSERT_EQ(o.status, Status::kOk);
  for (int a = 0; a < 3; ++a) {
    NoiseTerms<Scalar> f;
    ASSERT_EQ(fit_noise_terms(o.pts, o.n, a, f), Status::kOk);
    std::printf(" axis %d (chi2 %.1f / %d)\n", a, static_cast<double>(f.chi2), f.dof);
    expect_within("Q", as_double(f.q), q / std::sqrt(12.0));
    expect_within("N", as_double(f.n), density[a]);
  }
}

TEST(Allan, QuantisationDouble) { quantisation_recovered<double>(); }
TEST(Allan, QuantisationFloat) { quantisation_recovered<float>(); }

// Flicker from Gauss-Markov processes (time constants 0.01 .. 10000 s) over white noise. The
// truth is the sum's exact Allan variance; its floor is flat only to within the ripple of the
// 4-per-decade sum and bends down towards both ends of the time constants, while the model's B
// term is perfectly flat: B is asked to match the truth's floor to 25 % (the floor's own
// variation over the fitted taus plus the fit's sigma; the test prints both).
template <typename Scalar>
void flicker_recovered() {
  const double density[3] = {0.002, 0.002, 0.002};
  Series s = white(1000000 / (kScale > 1 ? 40 : 1), density, 0.0, 41);  // boards: 250 s
  const Flicker fl = add_flicker(s, 0.01, 10000.0, 1e-6, 42);
  static Overlapping<Scalar> o;
  overlapping(s, o);
  ASSERT_EQ(o.status, Status::kOk);
  // The truth's floor: the minimum of the true ADEV over the fitted taus beyond the white-noise
  // region, and its spread there.
  double lo = 1e30, hi = 0;
  for (double tau = 0.1; tau <= 0.1 * static_cast<double>(s.n()) * kDt; tau *= 1.2) {
    const double v = fl.avar(tau);
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  const double c = 2 * std::log(2.0) / 3.141592653589793;
  const double b_lo = std::sqrt(lo / c), b_hi = std::sqrt(hi / c);
  const double b_true = std::sqrt(b_lo * b_hi);
  std::printf(" true floor B %.4g .. %.4g (tau 0.1 s .. n dt / 10)\n", b_lo, b_hi);
  for (int a = 0; a < 3; ++a) {
    NoiseTerms<Scalar> f;
    ASSERT_EQ(fit_noise_terms(o.pts, o.n, a, f), Status::kOk);
    const double b = static_cast<double>(f.b.value), cb = static_cast<double>(f.classic_b);
    std::printf(" axis %d: B %.4g +- %.2g, classic %.4g at %.0f s (%.1f %%, %.1f %%)\n", a, b,
                static_cast<double>(f.b.sigma), cb, static_cast<double>(f.classic_b_tau),
                100 * (b / b_true - 1), 100 * (cb / b_true - 1));
    EXPECT_TRUE(f.b.significant);
    EXPECT_NEAR(b / b_true, 1.0, 0.25);
    // The classic read-out is one point (the smallest, so biased low): 25 % or 3 times that
    // point's own relative 68 % half-width, whichever is larger (short recordings: few edf).
    double half = 0;
    for (int i = 0; i < o.n; ++i) {
      if (o.pts[i].tau == f.classic_b_tau) {
        half = 0.5 * static_cast<double>(o.pts[i].adev_hi(a) - o.pts[i].adev_lo(a)) /
               std::sqrt(static_cast<double>(o.pts[i].avar(a)));
      }
    }
    EXPECT_GT(half, 0.0);
    EXPECT_NEAR(cb / b_true, 1.0, std::max(0.25, 3 * half));
    // N: the model's flat B cannot follow the truth's floor ripple (hi - lo in AVAR); where the
    // two terms cross (tau_c = N^2 / floor) the fit can move that into N^2 / tau_c, so N may be
    // off by up to (hi - lo) tau_c / (2 N) beyond its own 3 sigma.
    const double tau_c = density[a] * density[a] / lo;
    const double model_error = (hi - lo) * tau_c / (2 * density[a]);
    const double nv = static_cast<double>(f.n.value), ns = static_cast<double>(f.n.sigma);
    std::printf("  N %.6g +- %.2g, model error bound %.2g (truth %.6g)\n", nv, ns, model_error,
                density[a]);
    EXPECT_LE(std::fabs(nv - density[a]), 3 * ns + model_error);
  }
}

TEST(Allan, FlickerDouble) { flicker_recovered<double>(); }
TEST(Allan, FlickerFloat) { flicker_recovered<float>(); }

// The streaming accumulator (non-overlapping, octaves) against the overlapping estimate at the
// same taus on the same samples: their difference within 3 sigma of the accumulator's estimate
// (the less precise of the two; the two share the data, so the difference varies less).
template <typename Scalar>
void accumulator_matches_overlapping() {
  const double density[3] = {1.0, 0.3, 0.1};
  Series s = white(200000 / kScale, density, 32000.0, 51);
  add_random_walk(s, 0.05, 52);
  static AllanAccumulator<Scalar, 16> acc;
  AllanPoint<Scalar> dev[16];
  const int nd = accumulate(s, acc, dev);
  ASSERT_GE(nd, 8);
  const std::vector<Scalar> v = s.as<Scalar>();
  auto get = [&v](std::size_t i) { return Vector3<Scalar>(v[3 * i], v[3 * i + 1], v[3 * i + 2]); };
  double worst = 0;
  for (int k = 0; k < nd; ++k) {
    Vector3<Scalar> avar;
    std::uint32_t count = 0;
    ASSERT_EQ(overlapping_avar_at<Scalar>(get, s.n(), dev[k].m, avar, count), Status::kOk);
    for (int a = 0; a < 3; ++a) {
      const double d = static_cast<double>(dev[k].avar(a)), h = static_cast<double>(avar(a));
      const double sigma = d * std::sqrt(2.0 / static_cast<double>(dev[k].edf(a)));
      worst = std::max(worst, std::fabs(d - h) / sigma);
      EXPECT_LE(std::fabs(d - h), 3 * sigma) << "level " << k << " axis " << a;
      // The 68 % interval brackets the estimate.
      EXPECT_LT(dev[k].adev_lo(a), std::sqrt(dev[k].avar(a)));
      EXPECT_GT(dev[k].adev_hi(a), std::sqrt(dev[k].avar(a)));
    }
  }
  std::printf(" worst |accumulator - overlapping| %.2f sigma over %d octaves\n", worst, nd);
}

TEST(Allan, AccumulatorMatchesOverlappingDouble) { accumulator_matches_overlapping<double>(); }
TEST(Allan, AccumulatorMatchesOverlappingFloat) { accumulator_matches_overlapping<float>(); }

// Float on raw counts of ~33000 keeps the noise: the float accumulator matches the double one
// fed the same (float) samples. Without re-centring, float's rounding at 33000 (0.002 counts)
// would be a fifth of the longest level's cluster-mean differences (0.01 counts); re-centred, the
// arithmetic's error is 2^-24 of ~1 count, 1e-5 of those differences: 1e-4 is the bound.
TEST(AllanAccumulator, FloatKeepsPrecisionOnRawCounts) {
  const double density[3] = {0.05, 0.05, 0.05};  // 0.5 counts per sample on 33000
  Series s = white(100000 / kScale, density, 33000.0, 61);
  for (double& x : s.v) x = static_cast<double>(static_cast<float>(x));
  static AllanAccumulator<float, 12> af;
  static AllanAccumulator<double, 12> ad;
  AllanPoint<float> pf[12];
  AllanPoint<double> pd[12];
  const int nf = accumulate(s, af, pf), nd = accumulate(s, ad, pd);
  ASSERT_EQ(nf, nd);
  for (int k = 0; k < nf; ++k) {
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(static_cast<double>(pf[k].avar(a)) / pd[k].avar(a), 1.0, 1e-4);
    }
  }
}

// Bad readings among 5000 good ones, `bad` after every 997th, are refused with `why` and change
// nothing: every result as without them, and finite.
void expect_refused_nothing_lost(std::initializer_list<Vector3<float>> bad, Status why) {
  const double density[3] = {1.0, 1.0, 1.0};
  const Series s = white(5000, density, 100.0, 71);
  static AllanAccumulator<float, 8> a, b;
  ASSERT_EQ(a.start(0.01f), Status::kOk);
  ASSERT_EQ(b.start(0.01f), Status::kOk);
  for (std::size_t i = 0; i < s.n(); ++i) {
    const Vector3<float> x(static_cast<float>(s.v[3 * i]), static_cast<float>(s.v[3 * i + 1]),
                           static_cast<float>(s.v[3 * i + 2]));
    ASSERT_EQ(a.add(x), Status::kOk);
    ASSERT_EQ(b.add(x), Status::kOk);
    if (i % 997 == 0) {
      for (const Vector3<float>& v : bad) EXPECT_EQ(b.add(v), why) << v.transpose();
    }
  }
  EXPECT_EQ(a.samples(), b.samples());
  for (int k = 0; k < 8; ++k) {
    AllanPoint<float> pa, pb;
    ASSERT_EQ(a.result(k, pa), Status::kOk);
    ASSERT_EQ(b.result(k, pb), Status::kOk);
    EXPECT_EQ(pa.count, pb.count);
    for (int x = 0; x < 3; ++x) {
      EXPECT_EQ(pa.avar(x), pb.avar(x));
      EXPECT_TRUE(std::isfinite(pb.adev_lo(x)) && std::isfinite(pb.adev_hi(x)));
    }
  }
}

TEST(AllanAccumulator, NonFiniteRefusedNothingLost) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  expect_refused_nothing_lost({{1.0f, nan, 2.0f}, {inf, 1.0f, 2.0f}}, Status::kNonFiniteInput);
}

// A finite reading far from the others (float squares overflow above ~1.8e19; a difference of
// two finite readings can overflow too) is refused as a glitch and changes nothing, so no result
// is ever NaN or infinite; the overlapping estimate refuses such samples the same way.
TEST(AllanAccumulator, WildFiniteReadingRefusedNothingLost) {
  expect_refused_nothing_lost({{1.0f, 2e19f, 2.0f}, {-3e38f, 1.0f, 2.0f}, {1.0f, 2.0f, 1.1e12f}},
                              Status::kGlitch);
  // Readings up to 1e12 from the first, just within: every result finite, in float.
  static AllanAccumulator<float, 8> c;
  ASSERT_EQ(c.start(0.01f), Status::kOk);
  for (int i = 0; i < 4000; ++i) {
    const float v = (i * 7919) % 3 == 1 ? 0.999e12f : (i % 2 == 1 ? -0.999e12f : 0.0f);
    ASSERT_EQ(c.add(Vector3<float>(v, 0.0f, -v)), Status::kOk) << i;
  }
  for (int k = 0; k < 8; ++k) {
    AllanPoint<float> p;
    ASSERT_EQ(c.result(k, p), Status::kOk);
    for (int x = 0; x < 3; ++x) {
      EXPECT_TRUE(std::isfinite(p.avar(x)) && std::isfinite(p.edf(x))) << k;
      EXPECT_TRUE(std::isfinite(p.adev_lo(x)) && std::isfinite(p.adev_hi(x))) << k;
    }
  }
  // The overlapping estimate: one wild sample among 5000 is refused, nothing written.
  const double density[3] = {1.0, 1.0, 1.0};
  const Series s = white(5000, density, 100.0, 73);
  std::vector<float> v(3 * 5000, 100.0f);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<float>(s.v[i]);
  v[3 * 2500 + 1] = 2e19f;
  static AllanPoint<float> pts[kCapacity];
  int n_out = -1;
  EXPECT_EQ(overlapping_allan(v.data(), 5000, 3, 0.01f, 8, pts, kCapacity, n_out), Status::kGlitch);
  EXPECT_EQ(n_out, 0);
}

TEST(AllanAccumulator, TooFewSamplesGivesNoValue) {
  AllanAccumulator<float, 8> a;
  EXPECT_EQ(a.add(Vector3<float>::Zero()), Status::kNotStarted);
  EXPECT_EQ(a.start(0.0f), Status::kInvalidArgument);
  ASSERT_EQ(a.start(0.01f), Status::kOk);
  for (int i = 0; i < 10; ++i)
    ASSERT_EQ(a.add(Vector3<float>(float(i % 3), 1.0f, 2.0f)), Status::kOk);
  // 10 samples: level 0 has 9 differences, level 2 (clusters of 4) one, level 3 none.
  AllanPoint<float> p;
  p.tau = -1.0f;
  EXPECT_EQ(a.result(0, p), Status::kOk);
  EXPECT_EQ(p.count, 9u);
  EXPECT_EQ(a.result(2, p), Status::kOk);
  EXPECT_EQ(p.count, 1u);
  p.tau = -1.0f;
  EXPECT_EQ(a.result(3, p), Status::kTooFewSamples);
  EXPECT_EQ(p.tau, -1.0f);  // untouched
  EXPECT_EQ(a.result(8, p), Status::kInvalidArgument);
  for (int k = 0; k < 3; ++k) {
    ASSERT_EQ(a.result(k, p), Status::kOk);
    for (int x = 0; x < 3; ++x) {
      EXPECT_TRUE(std::isfinite(p.avar(x)));
      EXPECT_TRUE(std::isfinite(p.adev_lo(x)));
      EXPECT_TRUE(std::isfinite(p.adev_hi(x)));
    }
  }
  // A gap: the clusters in progress start over, what was summed stays.
  const std::uint32_t before = a.count(0);
  a.restart_run();
  EXPECT_EQ(a.count(0), before);
  ASSERT_EQ(a.add(Vector3<float>(5.0f, 5.0f, 5.0f)), Status::kOk);
  EXPECT_EQ(a.count(0), before);  // no difference across the gap
  ASSERT_EQ(a.add(Vector3<float>(5.0f, 5.0f, 5.0f)), Status::kOk);
  EXPECT_EQ(a.count(0), before + 1);
}

TEST(Allan, OverlappingBadInput) {
  std::vector<double> v(3 * 15, 1.0);
  AllanPoint<double> pts[4];
  int n = -1;
  // 15 samples: n/10 = 1 cluster size, too few for a curve.
  EXPECT_EQ(overlapping_allan<double>(v.data(), 15, 3, 0.01, 8, pts, 4, n), Status::kTooFewSamples);
  EXPECT_EQ(n, 0);
  auto get = [&v](std::size_t i) { return Vector3<double>(v[3 * i], v[3 * i + 1], v[3 * i + 2]); };
  Vector3<double> avar(-1, -1, -1);
  std::uint32_t count = 7;
  EXPECT_EQ(overlapping_avar_at<double>(get, 15, 8, avar, count), Status::kTooFewSamples);
  EXPECT_EQ(avar(0), -1.0);
  EXPECT_EQ(count, 7u);
  EXPECT_EQ(overlapping_avar_at<double>(get, 15, 0, avar, count), Status::kInvalidArgument);
  EXPECT_EQ(overlapping_avar_at<double>(get, 15, 7, avar, count), Status::kOk);
  EXPECT_EQ(count, 2u);
  EXPECT_EQ(avar(0), 0.0);
  // A NaN in the buffer: refused, no points.
  std::vector<double> w(3 * 1000, 1.0);
  w[3 * 500 + 1] = std::numeric_limits<double>::quiet_NaN();
  static AllanPoint<double> many[kCapacity];
  EXPECT_EQ(overlapping_allan<double>(w.data(), 1000, 3, 0.01, 8, many, kCapacity, n),
            Status::kNonFiniteInput);
  EXPECT_EQ(n, 0);
  // Bad arguments.
  EXPECT_EQ(overlapping_allan<double>(w.data(), 1000, 2, 0.01, 8, many, kCapacity, n),
            Status::kInvalidArgument);
  EXPECT_EQ(overlapping_allan<double>(w.data(), 1000, 3, -0.01, 8, many, kCapacity, n),
            Status::kInvalidArgument);
  // Capacity: the shortest taus filled, said so.
  const double density[3] = {1.0, 1.0, 1.0};
  const Series s = white(10000, density, 0.0, 81);
  EXPECT_EQ(overlapping_allan<double>(s.v.data(), s.n(), 3, 0.01, 8, pts, 4, n),
            Status::kCapacityExceeded);
  EXPECT_EQ(n, 4);
  EXPECT_EQ(pts[3].m, 4u);
  // The fit refuses what it cannot use.
  NoiseTerms<double> f;
  EXPECT_EQ(fit_noise_terms(pts, 1, 0, f), Status::kInvalidArgument);
  EXPECT_EQ(fit_noise_terms(pts, 4, 3, f), Status::kInvalidArgument);
  pts[2].avar(0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(fit_noise_terms(pts, 4, 0, f), Status::kNonFiniteInput);
}

// The xsens recording's initial rest (first 45 s, raw counts at ~100 Hz): each axis's white-noise
// density from the Allan deviation matches the per-sample scatter, std * sqrt(dt), within 3 sigma
// (the fit's and the scatter's own, std / sqrt(2 dof), in quadrature).
std::string xsens_dir() {
  const std::string dir = test::find_xsens_dir();
#ifdef IMUCAL_REQUIRE_XSENS
  if (dir.empty()) ADD_FAILURE() << "xsens recording required but not found";
#endif
  return dir;
}

TEST(AllanXsens, InitialRestNoiseDensityMatchesScatter) {
  const std::string dir = xsens_dir();
  if (dir.empty()) GTEST_SKIP() << "xsens recording not found (set IMUCAL_XSENS_DIR)";
  test::XsensStream in;
  ASSERT_TRUE(in.open(dir)) << in.error();
  Series acc, gyro;
  double t = 0, t0 = -1, t_last = 0;
  Vector3<float> a, g;
  while (in.next(t, a, g)) {
    if (t0 < 0) t0 = t;
    if (t - t0 > 45.0) break;
    t_last = t;
    for (int k = 0; k < 3; ++k) {
      acc.v.push_back(static_cast<double>(a(k)));
      gyro.v.push_back(static_cast<double>(g(k)));
    }
  }
  ASSERT_TRUE(in.error().empty()) << in.error();
  const std::size_t n = acc.n();
  ASSERT_GE(n, 4000u);
  const double dt = (t_last - t0) / static_cast<double>(n - 1);
  std::printf(" %zu samples, dt %.5f s\n", n, dt);
  const Series* sensors[2] = {&gyro, &acc};
  const char* names[2] = {"gyro", "accel"};
  for (int sen = 0; sen < 2; ++sen) {
    const std::vector<float> v = sensors[sen]->as<float>();
    static AllanPoint<float> pts[kCapacity];
    int np = 0;
    ASSERT_EQ(
        overlapping_allan<float>(v.data(), n, 3, static_cast<float>(dt), 8, pts, kCapacity, np),
        Status::kOk);
    for (std::size_t ax = 0; ax < 3; ++ax) {
      // The plain sample std also holds the slow part (bias instability: B^2 / (2 pi) ln(45 s /
      // 0.02 s) ~ 0.8 counts^2 on accelerometer z, 8 % of its variance); the scatter about the
      // mean of each 10-sample block (0.1 s) keeps the white noise and ~1/5 of that.
      const std::size_t block = 10;
      double m2 = 0, plain2 = 0, mean_all = 0;
      std::size_t dof = 0;
      for (std::size_t i = 0; i < n; ++i) mean_all += sensors[sen]->v[3 * i + ax];
      mean_all /= static_cast<double>(n);
      for (std::size_t b0 = 0; b0 + block <= n; b0 += block) {
        double mean = 0;
        for (std::size_t i = b0; i < b0 + block; ++i) mean += sensors[sen]->v[3 * i + ax];
        mean /= static_cast<double>(block);
        for (std::size_t i = b0; i < b0 + block; ++i) {
          const double d = sensors[sen]->v[3 * i + ax] - mean;
          m2 += d * d;
        }
        dof += block - 1;
      }
      for (std::size_t i = 0; i < n; ++i) {
        const double d = sensors[sen]->v[3 * i + ax] - mean_all;
        plain2 += d * d;
      }
      const double scatter = std::sqrt(m2 / static_cast<double>(dof) * dt);
      const double plain = std::sqrt(plain2 / static_cast<double>(n - 1) * dt);
      NoiseTerms<float> f;
      ASSERT_EQ(fit_noise_terms(pts, np, static_cast<int>(ax), f), Status::kOk);
      const double nv = static_cast<double>(f.n.value), ns = static_cast<double>(f.n.sigma);
      const double sigma = std::hypot(ns, scatter / std::sqrt(2.0 * static_cast<double>(dof)));
      std::printf(
          " %s %zu: N %.5g +- %.2g counts sqrt(s), scatter %.5g (%.2f sigma), plain std %.5g, "
          "classic %.5g; B %.3g%s K %.3g%s\n",
          names[sen], ax, nv, ns, scatter, std::fabs(nv - scatter) / sigma, plain,
          static_cast<double>(f.classic_n), static_cast<double>(f.b.value),
          f.b.significant ? "" : " (ns)", static_cast<double>(f.k.value),
          f.k.significant ? "" : " (ns)");
      EXPECT_TRUE(f.n.significant);
      EXPECT_LE(std::fabs(nv - scatter), 3 * sigma) << names[sen] << " axis " << ax;
    }
  }
}

}  // namespace
}  // namespace imucal
