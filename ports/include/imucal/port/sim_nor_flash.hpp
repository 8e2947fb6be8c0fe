// SPDX-License-Identifier: MIT
// imucal/port/sim_nor_flash.hpp: a simulated NOR flash in RAM, for tests on the host and on the
// cross targets. It enforces NOR semantics (erase to 0xFF per erase unit, program only clears
// bits, no program call across a page) and can cut the power after any number of byte
// operations: the byte being written when the power goes is left half-done (for a program, some
// of the bits it should clear; for an erase, some of the bits set), later bytes of that call are
// untouched, and every operation fails until power_on(). Never allocates.
#pragma once

#include <cstdint>
#include <cstring>

#include "imucal/store/flash_region.hpp"

namespace imucal {

template <std::uint32_t Size, std::uint32_t EraseSize = 4096, std::uint32_t PageSize = 256>
class SimNorFlash final : public FlashRegion {
 public:
  static_assert(Size % EraseSize == 0 && EraseSize % PageSize == 0, "geometry must nest");
  static constexpr std::uint32_t kNever = ~std::uint32_t(0);

  SimNorFlash() { std::memset(bytes_, 0xFF, sizeof bytes_); }

  FlashGeometry geometry() const override { return {Size, EraseSize, PageSize, 1, true}; }

  Status read(std::uint32_t offset, std::uint8_t* out, std::uint32_t size) override {
    if (!powered_) return Status::kStorageError;
    if (out == nullptr || !flash_range_ok(Size, offset, size)) return Status::kInvalidArgument;
    std::memcpy(out, bytes_ + offset, size);
    return Status::kOk;
  }

  Status program(std::uint32_t offset, const std::uint8_t* data, std::uint32_t size) override {
    if (!powered_) return Status::kStorageError;
    if (data == nullptr || !flash_range_ok(Size, offset, size)) return Status::kInvalidArgument;
    if (size > 0 && offset / PageSize != (offset + size - 1) / PageSize)
      return Status::kInvalidArgument;
    ++programs_;
    for (std::uint32_t i = 0; i < size; ++i) {
      std::uint8_t& b = bytes_[offset + i];
      if (cut_now()) {
        // Half-programmed: only the bits to clear in the low nibble got cleared.
        b = static_cast<std::uint8_t>(b & (data[i] | 0xF0u));
        return Status::kStorageError;
      }
      b = static_cast<std::uint8_t>(b & data[i]);
    }
    return Status::kOk;
  }

  Status erase(std::uint32_t offset) override {
    if (!powered_) return Status::kStorageError;
    if (offset % EraseSize != 0 || offset >= Size) return Status::kInvalidArgument;
    ++erases_;
    for (std::uint32_t i = 0; i < EraseSize; ++i) {
      std::uint8_t& b = bytes_[offset + i];
      if (cut_now()) {
        b = static_cast<std::uint8_t>(b | 0x0Fu);  // half-erased
        return Status::kStorageError;
      }
      b = 0xFF;
    }
    return Status::kOk;
  }

  // Power fails during the (n+1)-th byte operation from now (0: the very next one).
  void cut_power_after(std::uint32_t byte_operations) { budget_ = byte_operations; }
  void power_on() {
    powered_ = true;
    budget_ = kNever;
  }
  bool powered() const { return powered_; }
  std::uint32_t byte_operations() const { return byte_ops_; }  // since construction
  int programs() const { return programs_; }
  int erases() const { return erases_; }
  std::uint8_t* raw() { return bytes_; }  // for corrupting bytes in tests
  const std::uint8_t* raw() const { return bytes_; }

 private:
  bool cut_now() {
    ++byte_ops_;
    if (budget_ == kNever) return false;
    if (budget_ == 0) {
      powered_ = false;
      return true;
    }
    --budget_;
    return false;
  }

  std::uint8_t bytes_[Size];
  bool powered_ = true;
  std::uint32_t budget_ = kNever;
  std::uint32_t byte_ops_ = 0;
  int programs_ = 0, erases_ = 0;
};

}  // namespace imucal
