// SPDX-License-Identifier: MIT
// The file-backed flash port (host): NOR semantics on a file, and a record saved by one run of a
// program read back by the next (the file is the device's flash across reboots).
#include <gtest/gtest.h>

#include <cstdio>

#include "file_flash.hpp"
#include "imucal/store/record_store.hpp"
#include "support/gtest_status.hpp"

namespace imucal {
namespace {

constexpr FlashGeometry kGeometry{8192, 4096, 256};

CalibrationRecord accel_record(std::uint32_t id) {
  CalibrationRecord r;
  r.device_id = id;
  r.parts = kRecordAccel;
  r.calibration.accel.params << 0.0f, 0.0f, 0.0f, 1.0f, 1.0f, 1.0f, 0.1f, 0.2f, 0.3f;
  r.calibration.accel.poses = 12;
  r.calibration.accel.status = Status::kOk;
  return r;
}

TEST(FileFlash, KeepsTheRecordAcrossReopening) {
  const char* path = "test_file_flash.bin";
  std::remove(path);
  {
    FileFlash flash;
    ASSERT_EQ(flash.open(path, kGeometry), Status::kOk);
    RecordStore store(flash);
    CalibrationRecord out;
    EXPECT_EQ(store.load(out), Status::kNoRecord);  // created erased
    ASSERT_EQ(store.save(accel_record(1)), Status::kOk);
    ASSERT_EQ(store.save(accel_record(2)), Status::kOk);
  }
  FileFlash flash;
  ASSERT_EQ(flash.open(path, kGeometry), Status::kOk);
  RecordStore store(flash);
  CalibrationRecord out;
  ASSERT_EQ(store.load(out), Status::kOk);
  EXPECT_EQ(out.device_id, 2u);
  EXPECT_EQ(store.slot_status(0), Status::kOk);  // the previous one is still there
  flash.close();
  // A file of another region's size is refused, not overwritten.
  EXPECT_EQ(flash.open(path, FlashGeometry{4096, 4096, 256}), Status::kInvalidArgument);
  std::remove(path);
}

TEST(FileFlash, ProgramOnlyClearsBitsAndChecksItsArguments) {
  const char* path = "test_file_flash_nor.bin";
  std::remove(path);
  FileFlash flash;
  ASSERT_EQ(flash.open(path, kGeometry), Status::kOk);
  const std::uint8_t a[2] = {0xF0, 0x0F}, b[2] = {0x3C, 0xFF};
  std::uint8_t out[2] = {};
  ASSERT_EQ(flash.program(10, a, 2), Status::kOk);
  ASSERT_EQ(flash.program(10, b, 2), Status::kOk);
  ASSERT_EQ(flash.read(10, out, 2), Status::kOk);
  EXPECT_EQ(out[0], 0x30);
  EXPECT_EQ(out[1], 0x0F);
  EXPECT_EQ(flash.program(255, a, 2), Status::kInvalidArgument);  // crosses a page
  EXPECT_EQ(flash.read(8191, out, 2), Status::kInvalidArgument);
  EXPECT_EQ(flash.erase(100), Status::kInvalidArgument);
  ASSERT_EQ(flash.erase(0), Status::kOk);
  ASSERT_EQ(flash.read(10, out, 2), Status::kOk);
  EXPECT_EQ(out[0], 0xFF);
  EXPECT_EQ(FileFlash().open("/nonexistent-dir/x.bin", kGeometry), Status::kStorageError);
  flash.close();
  std::remove(path);
}

// With 16-byte program units (as STM32U5 flash): programs are whole, aligned units, and the
// store keeps its records there as well.
TEST(FileFlash, ProgramUnitsAreWholeAndTheStoreUsesThem) {
  const char* path = "test_file_flash_units.bin";
  std::remove(path);
  FileFlash flash;
  EXPECT_EQ(flash.open(path, FlashGeometry{8192, 4096, 256, 512, false}),
            Status::kInvalidArgument);  // a program unit above 256 bytes
  EXPECT_EQ(flash.open(path, FlashGeometry{8192, 4096, 8192, 16, false}),
            Status::kInvalidArgument);  // a page above the erase unit
  ASSERT_EQ(flash.open(path, FlashGeometry{8192, 4096, 256, 16, false}), Status::kOk);
  std::uint8_t a[32] = {};
  EXPECT_EQ(flash.program(8, a, 16), Status::kInvalidArgument);  // not aligned
  EXPECT_EQ(flash.program(16, a, 8), Status::kInvalidArgument);  // not a whole unit
  ASSERT_EQ(flash.program(16, a, 32), Status::kOk);
  ASSERT_EQ(flash.erase(0), Status::kOk);
  RecordStore store(flash);
  ASSERT_EQ(store.check_geometry(), Status::kOk);
  for (std::uint32_t id = 1; id <= 3; ++id) ASSERT_EQ(store.save(accel_record(id)), Status::kOk);
  CalibrationRecord out;
  ASSERT_EQ(RecordStore(flash).load(out), Status::kOk);
  EXPECT_EQ(out.device_id, 3u);
  flash.close();
  std::remove(path);
}

}  // namespace
}  // namespace imucal
