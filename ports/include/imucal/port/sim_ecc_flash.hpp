// SPDX-License-Identifier: MIT
// imucal/port/sim_ecc_flash.hpp: a simulated flash that fails as MCU flash with ECC does, for
// tests on the host and on the cross targets. Never allocates: the capacity is the template's.
//
//   - It programs whole program units (Unit bytes, aligned), each at most once between erases:
//     programming a unit twice fails (kStorageError) and is counted (double_programs()).
//   - The power can be cut at any step (one program unit programmed, or one erase call). The unit
//     being programmed is left torn; an erase cut leaves the units before the tear point erased,
//     one unit torn and the rest untouched. A torn unit reads back, as chosen with set_torn():
//     as an ECC error (the read fails), as arbitrary bits (the same on every read), or with a
//     weak bit that reads differently from one read to the next. Every operation fails until
//     power_on().
//   - A step can report a failure although it completed (report_failure_at_step()).
//   - Reads can fail (fail_next_reads(): an ECC error) or return one flipped bit
//     (flip_next_reads()) without anything on the flash being wrong: a misread. A burst of
//     misreads can also hit one area alone (misread_area(): a marginal cell, a noisy supply
//     while that area is read), up to two areas at once.
#pragma once

#include <cstdint>
#include <cstring>

#include "imucal/store/flash_region.hpp"

namespace imucal {

enum class TornReads : std::uint8_t { kEccError, kArbitrary, kWeak };

template <std::uint32_t Size, std::uint32_t EraseSize, std::uint32_t PageSize, std::uint32_t Unit>
class SimEccFlash final : public FlashRegion {
 public:
  static_assert(Unit >= 1 && Unit <= 256 && PageSize % Unit == 0 && EraseSize % PageSize == 0 &&
                    Size % EraseSize == 0,
                "geometry must nest");
  static constexpr std::uint32_t kNever = ~std::uint32_t(0);
  static constexpr std::uint32_t kUnits = Size / Unit;

  SimEccFlash() {
    for (std::uint32_t& d : dirty_) d = kUnitsPerErase;  // the arrays hold anything yet
    reset();
  }

  // Erased, powered, no fault armed, counters at zero.
  void reset() {
    for (std::uint32_t e = 0; e < kErases; ++e) erase_units(e * kUnitsPerErase, kUnitsPerErase);
    powered_ = true;
    cut_at_ = report_at_ = kNever;
    clear_read_faults();
    steps_ = 0;
    double_programs_ = 0;
  }

  FlashGeometry geometry() const override { return {Size, EraseSize, PageSize, Unit, false}; }

  Status read(std::uint32_t offset, std::uint8_t* out, std::uint32_t size) override {
    if (!powered_) return Status::kStorageError;
    if (out == nullptr || !flash_range_ok(Size, offset, size)) return Status::kInvalidArgument;
    if (fail_reads_ > 0) {
      --fail_reads_;
      return Status::kStorageError;
    }
    if (size == 0) return Status::kOk;
    std::uint32_t flip_at[kAreas];
    bool failed = false;
    for (int k = 0; k < kAreas; ++k) {
      Area& a = areas_[k];
      flip_at[k] = kNever;
      if (a.reads == 0 || offset >= a.offset + a.size || a.offset >= offset + size) continue;
      --a.reads;
      const std::uint32_t from = offset > a.offset ? offset : a.offset;
      const std::uint32_t to =
          offset + size < a.offset + a.size ? offset + size : a.offset + a.size;
      failed = failed || a.fail;
      flip_at[k] = from + (to - from) / 2 - offset;  // the middle of the part read
    }
    if (failed) return Status::kStorageError;
    for (std::uint32_t u = offset / Unit; u <= (offset + size - 1) / Unit; ++u)
      if (state_[u] == kTornEcc) return Status::kStorageError;
    std::memcpy(out, bytes_ + offset, size);
    for (std::uint32_t u = offset / Unit; u <= (offset + size - 1) / Unit; ++u) {
      if (state_[u] != kTornWeak) continue;
      // The weak bit: the unit's first byte inside the range, a bit chosen by the unit's index.
      const std::uint32_t at = u * Unit < offset ? offset : u * Unit;
      const std::uint8_t bit = static_cast<std::uint8_t>(1u << ((u * 5u) & 7u));
      if (next_random() & 1u) out[at - offset] = static_cast<std::uint8_t>(out[at - offset] ^ bit);
    }
    if (flip_reads_ > 0) {
      --flip_reads_;
      out[size / 2] = static_cast<std::uint8_t>(out[size / 2] ^ 0x04u);
    }
    for (std::uint32_t at : flip_at)
      if (at != kNever) out[at] = static_cast<std::uint8_t>(out[at] ^ 0x10u);
    return Status::kOk;
  }

  Status program(std::uint32_t offset, const std::uint8_t* data, std::uint32_t size) override {
    if (!powered_) return Status::kStorageError;
    if (data == nullptr || !flash_range_ok(Size, offset, size) || offset % Unit != 0 ||
        size % Unit != 0 || (size > 0 && offset / PageSize != (offset + size - 1) / PageSize))
      return Status::kInvalidArgument;
    ++programs_;
    bool report = false;
    for (std::uint32_t u = offset / Unit; u < (offset + size) / Unit; ++u) {
      if (state_[u] != kErased) {
        ++double_programs_;
        return Status::kStorageError;
      }
      const std::uint8_t* src = data + (u * Unit - offset);
      if (step(&report)) {
        tear(u, src);
        return Status::kStorageError;
      }
      std::memcpy(bytes_ + u * Unit, src, Unit);
      state_[u] = kProgrammed;
      touch(u);
    }
    return report ? Status::kStorageError : Status::kOk;
  }

  Status erase(std::uint32_t offset) override {
    if (!powered_) return Status::kStorageError;
    if (offset % EraseSize != 0 || offset >= Size) return Status::kInvalidArgument;
    ++erases_;
    bool report = false;
    const std::uint32_t first = offset / Unit, units = EraseSize / Unit;
    if (step(&report)) {
      const std::uint32_t torn = next_random() % units;
      erase_units(first, torn);
      tear(first + torn, nullptr);
      return Status::kStorageError;
    }
    erase_units(first, units);
    return report ? Status::kStorageError : Status::kOk;
  }

  // Power fails during the (n+1)-th step from now (0: the very next one). A step is one program
  // unit programmed or one erase call.
  void cut_power_at_step(std::uint32_t n) { cut_at_ = steps_ + n; }
  // The (n+1)-th step from now completes, but its call returns kStorageError.
  void report_failure_at_step(std::uint32_t n) { report_at_ = steps_ + n; }
  void set_torn(TornReads how) { torn_ = how; }
  void seed(std::uint32_t s) { rng_ = s != 0 ? s : 1u; }
  void fail_next_reads(int n) { fail_reads_ = n; }
  void flip_next_reads(int n) { flip_reads_ = n; }
  // The next n reads touching [offset, offset + size) fail (fail: an ECC error) or return one
  // flipped bit inside that area; other reads are right. Arms the first of two areas that has
  // no reads left (the second if both have).
  void misread_area(std::uint32_t offset, std::uint32_t size, int n, bool fail) {
    Area& a = areas_[0].reads == 0 ? areas_[0] : areas_[1];
    a = Area{offset, size, n, fail};
  }
  // Every read right from now on (fail_next_reads(), flip_next_reads(), misread_area()).
  void clear_read_faults() {
    fail_reads_ = flip_reads_ = 0;
    for (Area& a : areas_) a = Area{};
  }
  void power_on() {
    powered_ = true;
    cut_at_ = report_at_ = kNever;
  }

  bool powered() const { return powered_; }
  std::uint32_t steps() const { return steps_; }  // since reset()
  int programs() const { return programs_; }
  int erases() const { return erases_; }
  int double_programs() const { return double_programs_; }  // units programmed twice (refused)
  bool torn(std::uint32_t offset) const {
    return offset < Size && state_[offset / Unit] >= kTornEcc;
  }
  // For corrupting bytes in tests: every unit may then differ from erased.
  std::uint8_t* raw() {
    for (std::uint32_t& d : dirty_) d = kUnitsPerErase;
    return bytes_;
  }
  const std::uint8_t* raw() const { return bytes_; }

 private:
  enum : std::uint8_t { kErased, kProgrammed, kTornEcc, kTornArbitrary, kTornWeak };
  static constexpr int kAreas = 2;
  static constexpr std::uint32_t kErases = Size / EraseSize;
  static constexpr std::uint32_t kUnitsPerErase = EraseSize / Unit;
  struct Area {  // a burst of misreads of one area
    std::uint32_t offset = 0, size = 0;
    int reads = 0;  // misreads left
    bool fail = false;
  };

  // Counts a step; true if the power fails in it (it sets *report if it must report a failure).
  bool step(bool* report) {
    const std::uint32_t n = steps_++;
    if (n == report_at_) *report = true;
    if (n != cut_at_) return false;
    powered_ = false;
    return true;
  }
  // Erases the first n units of the erase unit that begins at unit `first`. Only those up to
  // its high-water mark can differ from erased (a save programs the first few hundred bytes of
  // a 128 KiB sector): the rest is not written again.
  void erase_units(std::uint32_t first, std::uint32_t n) {
    std::uint32_t& d = dirty_[first / kUnitsPerErase];
    const std::uint32_t m = n < d ? n : d;
    std::memset(bytes_ + first * Unit, 0xFF, m * Unit);
    std::memset(state_ + first, kErased, m);
    if (n >= d) d = 0;
  }
  // Unit u may differ from erased from now on.
  void touch(std::uint32_t u) {
    std::uint32_t& d = dirty_[u / kUnitsPerErase];
    const std::uint32_t end = u % kUnitsPerErase + 1;
    d = end > d ? end : d;
  }
  // A unit left half-done: `intended` is what a program meant to write (nullptr: an erase).
  void tear(std::uint32_t u, const std::uint8_t* intended) {
    std::uint8_t* p = bytes_ + u * Unit;
    touch(u);
    switch (torn_) {
      case TornReads::kEccError:
        state_[u] = kTornEcc;
        break;
      case TornReads::kArbitrary:
        for (std::uint32_t i = 0; i < Unit; ++i) p[i] = static_cast<std::uint8_t>(next_random());
        state_[u] = kTornArbitrary;
        break;
      case TornReads::kWeak:
        if (intended != nullptr)
          std::memcpy(p, intended, Unit);
        else
          std::memset(p, 0xFF, Unit);
        state_[u] = kTornWeak;
        break;
    }
  }
  std::uint32_t next_random() {  // xorshift32
    rng_ ^= rng_ << 13;
    rng_ ^= rng_ >> 17;
    rng_ ^= rng_ << 5;
    return rng_;
  }

  std::uint8_t bytes_[Size];
  std::uint8_t state_[kUnits];
  // Per erase unit: how many of its program units, from its start, may differ from erased.
  std::uint32_t dirty_[kErases];
  bool powered_ = true;
  TornReads torn_ = TornReads::kEccError;
  std::uint32_t cut_at_ = kNever, report_at_ = kNever;
  std::uint32_t steps_ = 0;
  std::uint32_t rng_ = 0x9E3779B9u;
  int fail_reads_ = 0, flip_reads_ = 0;
  Area areas_[kAreas];
  int programs_ = 0, erases_ = 0, double_programs_ = 0;
};

}  // namespace imucal
