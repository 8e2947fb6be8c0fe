// imucal/port/flash_region.hpp: the storage port. A small region of NOR-like flash that the
// record store (imucal/record_store.hpp) keeps calibration records in. The firmware implements
// it over its flash driver; ports/ has a simulated NOR flash (sim_nor_flash.hpp, any target) and
// a file-backed one (ports/host/file_flash.hpp, host). Implementations must not allocate or
// throw; they may block for the duration of one erase or program operation.
//
// The semantics the store relies on (those of NOR flash):
//   - erase(offset) sets one whole erase unit (erase_size bytes, offset aligned) to 0xFF;
//   - program(offset, data, n) can only clear bits (new = old AND data), and one call never
//     crosses a page boundary (page_size bytes);
//   - read(offset, out, n) reads any range inside the region.
// Each returns kOk, kInvalidArgument (out of range, misaligned, crossing a page) or
// kStorageError (the device failed, or power was lost during the operation).
#pragma once

#include <cstdint>

#include "imucal/status.hpp"

namespace imucal {

struct FlashGeometry {
  std::uint32_t size = 0;        // bytes in the region
  std::uint32_t erase_size = 0;  // erase unit (sector), divides size
  std::uint32_t page_size = 0;   // program unit, divides erase_size
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

}  // namespace imucal
