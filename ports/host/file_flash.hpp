// SPDX-License-Identifier: MIT
// ports/host/file_flash.hpp: a flash region backed by a file on the host (the `imucal` tool,
// tests, a desktop build of the firmware). The file holds the region's bytes and behaves as NOR
// flash: erase writes 0xFF over an erase unit, program ANDs the bits in, a program call writes
// whole program units and may not cross a page (of at most 4096 bytes). Every operation is
// flushed before it returns. Host only (stdio).
#pragma once

#include <cstdint>
#include <cstdio>

#include "imucal/store/flash_region.hpp"

namespace imucal {

class FileFlash final : public FlashRegion {
 public:
  static constexpr std::uint32_t kMaxPage = 4096;

  FileFlash() = default;
  ~FileFlash();
  FileFlash(const FileFlash&) = delete;
  FileFlash& operator=(const FileFlash&) = delete;

  // Opens `path`, creating it erased (all 0xFF) if it does not exist. kInvalidArgument for a
  // geometry that does not nest (flash_geometry_nests()), a page above kMaxPage or a file of
  // another size; kStorageError if it cannot be opened.
  Status open(const char* path, FlashGeometry geometry);
  void close();

  FlashGeometry geometry() const override { return geometry_; }
  Status read(std::uint32_t offset, std::uint8_t* out, std::uint32_t size) override;
  Status program(std::uint32_t offset, const std::uint8_t* data, std::uint32_t size) override;
  Status erase(std::uint32_t offset) override;

 private:
  std::FILE* file_ = nullptr;
  FlashGeometry geometry_{};
};

}  // namespace imucal
