// SPDX-License-Identifier: MIT
#include "support/xsens_reader.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace imucal::test {

std::string find_xsens_dir() {
#ifdef IMUCAL_XSENS_DEFAULT_DIR
  const char* built_in = IMUCAL_XSENS_DEFAULT_DIR;
#else
  const char* built_in = "";
#endif
  const char* env = std::getenv("IMUCAL_XSENS_DIR");
  for (const char* dir : {env, built_in, "../shared/data/xsens"}) {
    if (dir == nullptr || *dir == '\0') continue;
    const std::string path = std::string(dir) + "/xsens_acc.mat";
    if (std::FILE* f = std::fopen(path.c_str(), "r")) {
      std::fclose(f);
      return dir;
    }
  }
  return {};
}

bool read_txyz(const std::string& path, std::vector<Sample>& out, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = path + ": cannot open";
    return false;
  }
  out.reserve(out.size() + 60000);
  std::string line;
  std::size_t lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::istringstream ss(line);
    Sample s{};
    if (!(ss >> s.t >> s.v(0) >> s.v(1) >> s.v(2))) {
      error = path + ":" + std::to_string(lineno) + ": expected 4 numbers";
      return false;
    }
    out.push_back(s);
  }
  return true;
}

XsensStream::~XsensStream() {
  if (acc_ != nullptr) std::fclose(acc_);
  if (gyro_ != nullptr) std::fclose(gyro_);
}

bool XsensStream::open(const std::string& dir) {
  acc_ = std::fopen((dir + "/xsens_acc.mat").c_str(), "r");
  gyro_ = std::fopen((dir + "/xsens_gyro.mat").c_str(), "r");
  if (acc_ == nullptr || gyro_ == nullptr) {
    error_ = dir + ": cannot open xsens_acc.mat and xsens_gyro.mat";
    return false;
  }
  return true;
}

bool XsensStream::next(double& t, Vector3<float>& acc, Vector3<float>& gyro) {
  double ta = 0, tg = 0, a[3] = {}, g[3] = {};
  const int na = std::fscanf(acc_, "%lf %lf %lf %lf", &ta, &a[0], &a[1], &a[2]);
  const int ng = std::fscanf(gyro_, "%lf %lf %lf %lf", &tg, &g[0], &g[1], &g[2]);
  if (na == EOF && ng == EOF) return false;
  ++line_;
  if (na != 4 || ng != 4 || ta != tg) {
    error_ = "line " + std::to_string(line_) + ": malformed or mismatched timestamps";
    return false;
  }
  t = ta;
  acc = Vector3<double>(a[0], a[1], a[2]).cast<float>();
  gyro = Vector3<double>(g[0], g[1], g[2]).cast<float>();
  return true;
}

std::vector<Interval> detect_still(const std::vector<Sample>& acc, double init_seconds, double k,
                                   int half_window, std::size_t trim, std::size_t min_samples) {
  auto variance_norm = [&](std::size_t b, std::size_t e) {
    Vector3<double> m = Vector3<double>::Zero(), q = Vector3<double>::Zero();
    for (std::size_t i = b; i < e; ++i) {
      const Vector3<double> v = acc[i].v.cast<double>();
      m += v;
      q += v.cwiseProduct(v);
    }
    const double n = static_cast<double>(e - b);
    m /= n;
    return (q / n - m.cwiseProduct(m)).norm();
  };
  std::size_t init_end = 0;
  while (init_end < acc.size() && acc[init_end].t - acc[0].t < static_cast<float>(init_seconds))
    ++init_end;
  const double threshold = k * variance_norm(0, init_end);

  const std::size_t w = static_cast<std::size_t>(half_window);
  std::vector<bool> still(acc.size(), false);
  for (std::size_t i = 0; i < init_end; ++i) still[i] = true;
  for (std::size_t i = w; i + w < acc.size(); ++i) {
    if (i >= init_end) still[i] = variance_norm(i - w, i + w + 1) < threshold;
  }
  std::vector<Interval> out;
  std::size_t i = 0;
  while (i < acc.size()) {
    if (!still[i]) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < acc.size() && still[j]) ++j;
    if (j - i >= min_samples + 2 * trim) out.push_back({i + trim, j - trim});
    i = j;
  }
  return out;
}

}  // namespace imucal::test
