// SPDX-License-Identifier: MIT
// imucal/store/flash_region.hpp: the storage port. A small region of flash that the record store
// (imucal/store/record_store.hpp) keeps calibration records in. The firmware implements it over its
// flash driver; ports/ has simulated flashes (sim_nor_flash.hpp: byte-programmable NOR;
// sim_ecc_flash.hpp: program units with ECC that fail like real parts; both any target) and a
// file-backed one (ports/host/file_flash.hpp, host). Implementations must not allocate or throw;
// they may block for the duration of one erase or program operation.
//
// The semantics the store relies on:
//   - erase(offset) sets one whole erase unit (erase_size bytes, offset aligned) to 0xFF;
//   - program(offset, data, n) writes whole program units (program_unit bytes, offset and n
//     multiples of it) and never crosses a page boundary (page_size bytes, the most one call
//     writes); on NOR flash it can only clear bits;
//   - read(offset, out, n) reads any range inside the region.
// Each returns kOk, kInvalidArgument (out of range, misaligned, crossing a page) or
// kStorageError (the device failed, an ECC error on read, or power was lost during the
// operation).
//
// Many MCU flashes program in fixed units with ECC and forbid programming a unit twice between
// erases (STM32L4/G4: 8 bytes, STM32U5: 16, STM32H7: 32); a unit whose programming was cut by a
// power loss may read back as an ECC error, as arbitrary bits, or differently on two reads. The
// store programs every unit at most once per erase and never relies on `program_twice`.
#pragma once

#include <cstdint>

#include "imucal/status.hpp"

namespace imucal {

struct FlashGeometry {
  std::uint32_t size = 0;          // bytes in the region
  std::uint32_t erase_size = 0;    // erase unit (sector), divides size
  std::uint32_t page_size = 0;     // the most one program call writes, divides erase_size
  std::uint32_t program_unit = 1;  // smallest programmable unit (1..256), divides page_size
  bool program_twice = true;       // a unit may be programmed again before an erase (bits AND)
};

class FlashRegion {
 public:
  virtual FlashGeometry geometry() const = 0;
  virtual Status read(std::uint32_t offset, std::uint8_t* out, std::uint32_t size) = 0;
  virtual Status program(std::uint32_t offset, const std::uint8_t* data, std::uint32_t size) = 0;
  virtual Status erase(std::uint32_t offset) = 0;

 protected:
  FlashRegion() = default;
  FlashRegion(const FlashRegion&) = default;
  FlashRegion& operator=(const FlashRegion&) = default;
  ~FlashRegion() = default;  // not deleted through this interface
};

// Whether [offset, offset + size) lies inside a region of `region` bytes (overflow-safe).
inline bool flash_range_ok(std::uint32_t region, std::uint32_t offset, std::uint32_t size) {
  return offset <= region && size <= region - offset;
}

// Whether the units nest (program unit | page | erase unit | size, none zero, program unit at
// most 256 bytes). No division by zero, no overflow for any values.
inline bool flash_geometry_nests(const FlashGeometry& g) {
  return g.program_unit >= 1 && g.program_unit <= 256 && g.page_size != 0 &&
         g.page_size % g.program_unit == 0 && g.erase_size != 0 &&
         g.erase_size % g.page_size == 0 && g.size != 0 && g.size % g.erase_size == 0;
}

}  // namespace imucal
