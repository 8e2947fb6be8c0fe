// SPDX-License-Identifier: MIT
#include "file_flash.hpp"

#include <cstdint>

namespace imucal {

FileFlash::~FileFlash() { close(); }

void FileFlash::close() {
  if (file_ != nullptr) std::fclose(file_);
  file_ = nullptr;
  geometry_ = FlashGeometry{};
}

Status FileFlash::open(const char* path, FlashGeometry g) {
  close();
  if (path == nullptr || !flash_geometry_nests(g) || g.page_size > kMaxPage)
    return Status::kInvalidArgument;
  file_ = std::fopen(path, "r+b");
  if (file_ == nullptr) {
    file_ = std::fopen(path, "w+b");
    if (file_ == nullptr) return Status::kStorageError;
    for (std::uint32_t i = 0; i < g.size; ++i)
      if (std::fputc(0xFF, file_) == EOF) {
        close();
        return Status::kStorageError;
      }
    if (std::fflush(file_) != 0) {
      close();
      return Status::kStorageError;
    }
  }
  if (std::fseek(file_, 0, SEEK_END) != 0 || std::ftell(file_) != static_cast<long>(g.size)) {
    close();
    return Status::kInvalidArgument;  // another region's file
  }
  geometry_ = g;
  return Status::kOk;
}

Status FileFlash::read(std::uint32_t offset, std::uint8_t* out, std::uint32_t size) {
  if (file_ == nullptr) return Status::kStorageError;
  if (out == nullptr || !flash_range_ok(geometry_.size, offset, size))
    return Status::kInvalidArgument;
  if (std::fseek(file_, static_cast<long>(offset), SEEK_SET) != 0 ||
      std::fread(out, 1, size, file_) != size)
    return Status::kStorageError;
  return Status::kOk;
}

Status FileFlash::program(std::uint32_t offset, const std::uint8_t* data, std::uint32_t size) {
  if (file_ == nullptr) return Status::kStorageError;
  const std::uint32_t unit = geometry_.program_unit;
  if (data == nullptr || !flash_range_ok(geometry_.size, offset, size) ||
      size > geometry_.page_size || offset % unit != 0 || size % unit != 0 ||
      (size > 0 && offset / geometry_.page_size != (offset + size - 1) / geometry_.page_size))
    return Status::kInvalidArgument;
  std::uint8_t page[kMaxPage];
  Status s = read(offset, page, size);
  if (s != Status::kOk) return s;
  for (std::uint32_t i = 0; i < size; ++i) page[i] = static_cast<std::uint8_t>(page[i] & data[i]);
  if (std::fseek(file_, static_cast<long>(offset), SEEK_SET) != 0 ||
      std::fwrite(page, 1, size, file_) != size || std::fflush(file_) != 0)
    return Status::kStorageError;
  return Status::kOk;
}

Status FileFlash::erase(std::uint32_t offset) {
  if (file_ == nullptr) return Status::kStorageError;
  if (offset % geometry_.erase_size != 0 || offset >= geometry_.size)
    return Status::kInvalidArgument;
  if (std::fseek(file_, static_cast<long>(offset), SEEK_SET) != 0) return Status::kStorageError;
  for (std::uint32_t i = 0; i < geometry_.erase_size; ++i)
    if (std::fputc(0xFF, file_) == EOF) return Status::kStorageError;
  return std::fflush(file_) == 0 ? Status::kOk : Status::kStorageError;
}

}  // namespace imucal
